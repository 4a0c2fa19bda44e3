"""``hybridlab check MODEL``: validate a model file and summarise it."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hybridlab.model.schema import Model

from hybridlab.cli._args import EXIT_OK
from hybridlab.cli._commands import HELP
from hybridlab.errors import ModelError

__all__ = ["add_parser", "summary"]


def summary(model: Model) -> str:
    """The summary ``check`` prints: states (continuous and discrete), parameters, modes,
    transitions, scenarios, and for a model built from components its network (instances,
    connections, labels).

    Examples
    --------
    >>> from hybridlab import load_model
    >>> print(summary(load_model("models/bouncing_ball.toml")).splitlines()[0])
    model 'bouncing_ball': OK
    >>> print(*summary(load_model("models/two_rooms.toml")).splitlines()[2:12], sep="\\n")
      instances (3):
        room1: template 'room' from models/two_rooms.toml
        room2: template 'room' from models/two_rooms.toml
        heater: template 'heater' from models/two_rooms.toml
      connections (2): room1.T_other <- room2.T, room2.T_other <- room1.T
      labels (4):
        start1: room1.turn_on, heater.grant1
        stop1: room1.turn_off, heater.release1
        start2: room2.turn_on, heater.grant2
        stop2: room2.turn_off, heater.release2
    """
    from hybridlab._text import printable

    lines = [f"model {model.name!r}: OK"]
    if model.description:
        lines.append(f"  {' '.join(model.description.split())}")
    if model.network is not None:
        lines.extend(model.network.describe())
    lines.append(f"  states: {len(model.states)} continuous, {len(model.discrete)} discrete")
    if model.states:
        lines.append(f"    continuous: {', '.join(model.states)}")
    if model.discrete:
        lines.append("    discrete: " + ", ".join(f"{name} ({var.type})"
                                                 for name, var in model.discrete.items()))
    lines.append(f"  parameters ({len(model.parameters)}): {', '.join(model.parameters) or '-'}")
    lines.append(f"  modes ({len(model.modes)}), initial {model.initial.mode!r}:")
    lines.extend(_modes(model))
    lines.append(f"  transitions ({len(model.transitions)}):")
    for tr in model.transitions:
        when = " and ".join(tr.guard) or "-"
        if tr.schedule:
            when += f" every {tr.schedule.period}"
        prio = "" if tr.priority is None else f" priority {tr.priority}"
        source = tr.source if isinstance(tr.source, str) else ", ".join(tr.source)
        lines.append(f"    {printable(tr.name)}: {printable(source)} -> {printable(tr.target)} "
                     f"when {when}{prio}")
    if model.scenarios:
        lines.append("  scenarios: " + ", ".join(f"{printable(k)} (t_end {v.t_end:g})"
                                                for k, v in model.scenarios.items()))
    return "\n".join(lines)


def _modes(model: Model) -> list[str]:
    """One line per mode: its outgoing transitions, invariants and the discontinuities of
    its flow (the switching surfaces the simulator locates).

    The lines come from the checked symbolic model; a mechanics model's equations of
    motion are derived (which fails on a singular mass matrix), but no numeric code is
    generated, so numpy is not loaded.

    Examples
    --------
    >>> from hybridlab import load_model
    >>> _modes(load_model("models/friction_oscillator.toml"))
    ['    move: 0 outgoing, 0 invariant(s); discontinuities: sign(v)']
    """
    from hybridlab._text import printable
    from hybridlab.symbolic.discontinuities import extract_switches
    from hybridlab.symbolic.lagrange import mode_flow, model_equations

    sym = model.symbolic
    if sym is None:
        raise ModelError("model has not been checked")
    equations = model_equations(sym)
    lines = []
    discontinuities: dict[tuple, str] = {}  # by flow: modes of a product often share one
    for name, mode in sym.modes.items():
        outgoing = sum(tr.source == name for tr in sym.transitions)
        flow = mode_flow(sym, name, equations)
        if flow not in discontinuities:
            switches = extract_switches(flow, prefix="_sigma")[1]
            discontinuities[flow] = ("; discontinuities: " + ", ".join(s.text for s in switches)
                                     if switches else "")
        lines.append(f"    {printable(name)}: {outgoing} outgoing, "
                     f"{len(mode.invariants)} invariant(s){discontinuities[flow]}")
    return lines


def _run(args: argparse.Namespace) -> int:
    from hybridlab.model.loader import load_model

    print(summary(load_model(args.model)))
    return EXIT_OK


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``check`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["check", "models/thermostat.toml"])
    >>> args.command, args.model, args.run.__name__
    ('check', 'models/thermostat.toml', '_run')
    """
    p: argparse.ArgumentParser = sub.add_parser("check", help=HELP["check"])
    p.add_argument("model")
    p.set_defaults(run=_run)
    return p
