"""The commands of the command line, listed without importing them.

``hybridlab --help`` needs only each command's name and one-line help, so they
are written here; a command's module (its options and the code that runs it) is
imported only when that command is the one run. Each module's ``add_parser``
reads its help line from :data:`HELP`, so the two listings cannot drift apart.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

__all__ = ["COMMANDS", "HELP", "Command", "command_of"]


class Command(NamedTuple):
    """One subcommand: its name, the module that defines and runs it, its help line.

    Examples
    --------
    >>> check = Command("check", "hybridlab.cli.check", "validate a model file and summarise it")
    >>> check.module
    'hybridlab.cli.check'
    """

    name: str
    module: str
    help: str


#: the commands, in the order ``--help`` lists them
COMMANDS: tuple[Command, ...] = (
    Command("check", "hybridlab.cli.check", "validate a model file and summarise it"),
    Command("simulate", "hybridlab.cli.simulate", "simulate a model"),
    Command("graph", "hybridlab.cli.graph", "print the mode graph in Graphviz DOT, or check it"),
    Command("identify", "hybridlab.cli.identify", "identify parameters from measured data"),
    Command("import", "hybridlab.cli.importers", "convert a model from another format to TOML"),
    Command("sweep", "hybridlab.cli.sweep",
            "simulate a model over a grid of parameters/initial states, write CSV"),
    Command("reach", "hybridlab.cli.reach", "check safety specs from an initial set: SAFE "
                                            "(proved), UNSAFE (counterexample) or UNKNOWN"),
    Command("flatten", "hybridlab.cli.flatten",
            "write a model built from components as one flat model file"),
    Command("schema", "hybridlab.cli.schema", "print the JSON schema of model files"),
)

#: each command's help line, by name
HELP: dict[str, str] = {command.name: command.help for command in COMMANDS}


def command_of(argv: Sequence[str]) -> Command | None:
    """The command ``argv`` (the arguments after ``hybridlab``) runs, if it names one.

    The top-level parser has no option that takes a value, so the first argument
    that is not an option is the command, as argparse reads it.

    Examples
    --------
    >>> command_of(["check", "models/thermostat.toml"]).module
    'hybridlab.cli.check'
    >>> command_of(["--help"]) is None, command_of(["bogus", "x"]) is None
    (True, True)
    """
    first = next((arg for arg in argv if not arg.startswith("-")), None)
    return next((command for command in COMMANDS if command.name == first), None)
