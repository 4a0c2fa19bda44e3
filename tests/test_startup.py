"""Start-up: ``--help`` loads no numerical library, ``check`` no numpy; every help is intact.

The command line imports a command's module only when that command runs, so the
parser it builds lists the other commands by name and help line alone. These
tests hold the help texts to those of a parser built eagerly from every command
module, and look at ``sys.modules`` of a fresh process (no timing: the times are
in ``benchmarks/startup.py``).
"""

from __future__ import annotations

import argparse
import importlib
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from hybridlab.cli import _parser, main
from hybridlab.cli._args import Parser
from hybridlab.cli._commands import COMMANDS

ROOT = Path(__file__).resolve().parents[1]

#: libraries that take a noticeable share of a second to import
NUMERICAL = {"numpy", "scipy", "sympy", "pydantic", "networkx", "numba", "flint", "highspy",
             "mpmath", "matplotlib", "pandas"}


def _eager_parser() -> Parser:
    """The command line's parser with every command module imported and defined."""
    lazy = _parser([])
    parser = Parser(prog=lazy.prog, description=lazy.description)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in COMMANDS:
        importlib.import_module(command.module).add_parser(sub)
    return parser


def _nested(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
            ) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """Every parser under ``parser`` (``identify friction``, ...) with its command path."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from _nested(child, (*path, name))


HELPS = [path for path, _ in _nested(_eager_parser())]


@pytest.mark.parametrize("path", HELPS, ids=[" ".join(p) or "hybridlab" for p in HELPS])
def test_every_help_is_that_of_the_eager_parser(path: tuple[str, ...],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    expected = dict(_nested(_eager_parser()))[path].format_help()
    assert main([*path, "--help"]) == 0
    assert capsys.readouterr().out == expected


def test_the_listing_names_every_command_in_order() -> None:
    text = _parser([]).format_help()
    positions = [text.index(f"    {command.name} ") for command in COMMANDS]
    assert positions == sorted(positions)
    assert all(" ".join(command.help.split()[:3]) in text for command in COMMANDS)


_PROBE = """
import json, sys
from hybridlab.cli import main

def run(*argv):
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = exc.code
    return code

codes = [run("--help")]
top = sorted(sys.modules)
codes += [run(*path, "--help") for path in json.loads(sys.argv[1])]
helps = sorted(sys.modules)
codes.append(run("check", "models/bouncing_ball.toml"))
print(json.dumps({"codes": codes, "top": top, "helps": helps, "check": sorted(sys.modules)}))
"""


@pytest.fixture(scope="module")
def loaded() -> dict:
    """The modules a fresh process holds after ``--help``, after every command's ``--help``
    and after ``check``; and the exit codes."""
    out = subprocess.run([sys.executable, "-c", _PROBE, json.dumps([p for p in HELPS if p])],
                         cwd=ROOT, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def _roots(modules: list[str]) -> set[str]:
    return {name.split(".")[0] for name in modules}


def test_every_help_and_check_exit_0(loaded: dict) -> None:
    assert loaded["codes"] == [0] * (len(HELPS) + 1)


def test_top_level_help_loads_only_the_command_line(loaded: dict) -> None:
    ours = {name for name in loaded["top"] if name.startswith("hybridlab")}
    assert not _roots(loaded["top"]) & NUMERICAL
    # none of the layers below (model, simulation, reachability, ...), no command module
    assert ours <= {"hybridlab", "hybridlab._lazy", "hybridlab.errors", "hybridlab.cli",
                    "hybridlab.cli._args", "hybridlab.cli._commands"}


def test_command_helps_load_no_numerical_library(loaded: dict) -> None:
    assert not _roots(loaded["helps"]) & NUMERICAL
    assert not [name for name in loaded["helps"]
                if name.startswith(("hybridlab.simulation.", "hybridlab.reachability."))
                and not name.endswith(".options")]


def test_check_loads_no_numpy_scipy_or_engine(loaded: dict) -> None:
    assert not _roots(loaded["check"]) & {"numpy", "scipy", "networkx", "numba", "highspy"}
    assert not [name for name in loaded["check"]
                if name.startswith(("hybridlab.simulation.", "hybridlab.reachability."))
                and not name.endswith(".options")]
