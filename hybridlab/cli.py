"""The ``hybridlab`` command line.

Exit codes: 0 success; 2 user error (bad model, file or argument: one line on
stderr, no traceback); 3 a simulation that ended before ``t_end`` (its status
says why); 4 ``graph --check`` reported a warning or an error; 1 an internal
error.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import traceback
from collections.abc import Sequence
from pathlib import Path

from hybridlab._cliargs import finite_number, require_finite, split_assignment
from hybridlab._files import replace_text
from hybridlab._text import printable
from hybridlab.ensemble.cli import add_sweep_parser
from hybridlab.errors import HybridlabError, ModelError, SimulationError
from hybridlab.graph import check_mode_graph, to_dot
from hybridlab.identify.cli import add_identify_parser
from hybridlab.io.cli import add_import_parser
from hybridlab.model.loader import load_model, model_json_schema
from hybridlab.model.schema import Model
from hybridlab.reachability.cli import add_reach_parser
from hybridlab.simulation.api import simulate
from hybridlab.simulation.options import METHODS
from hybridlab.simulation.result import Status
from hybridlab.symbolic.compile import compile_model

__all__ = ["main"]

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INCOMPLETE, EXIT_FINDINGS = 0, 1, 2, 3, 4
#: the shell's code for a process ended by SIGINT; the partial result is still printed
EXIT_INTERRUPTED = 130
#: an unexpected internal error (a bug in hybridlab): sysexits' EX_SOFTWARE
EXIT_BUG = 70


class _UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, not usage + message
        raise _UsageError(message)


def _assignments(items: Sequence[str] | None, option: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or ():
        name, value = split_assignment(item, option, error=_UsageError)
        out[name] = finite_number(value, f"{option} {name}", error=_UsageError)
    return out


def _summary(model: Model) -> str:
    compiled = compile_model(model)
    lines = [f"model {model.name!r}: OK"]
    if model.description:
        lines.append(f"  {' '.join(model.description.split())}")
    lines.append(f"  states ({len(model.states)}): {', '.join(model.states)}")
    lines.append(f"  parameters ({len(model.parameters)}): {', '.join(model.parameters) or '-'}")
    lines.append(f"  modes ({len(model.modes)}), initial {model.initial.mode!r}:")
    for name, mode in compiled.modes.items():
        extra = ""
        if mode.switches:
            extra = "; discontinuities: " + ", ".join(s.text for s in mode.switches)
        lines.append(f"    {printable(name)}: {len(mode.outgoing)} outgoing, "
                     f"{len(mode.invariant_texts)} invariant(s){extra}")
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


def _cmd_check(args: argparse.Namespace) -> int:
    print(_summary(load_model(args.model)))
    return EXIT_OK


def _cmd_simulate(args: argparse.Namespace) -> int:
    # check every argument before the (possibly long) simulation runs
    for option in ("t_end", "rtol", "atol", "max_step", "time_limit"):
        require_finite(getattr(args, option), "--" + option.replace("_", "-"), error=_UsageError)
    params = _assignments(args.set, "--set")
    initial = _assignments(args.init, "--init")
    out = Path(args.out) if args.out else None
    if out is not None and out.suffix.lower() not in (".json", ".csv", ".npz"):
        raise _UsageError(f"--out must end in .json, .csv or .npz (got {args.out!r})")
    model = load_model(args.model)
    kwargs = {}
    if args.zeno:
        kwargs["zeno"] = args.zeno
    if args.backend:
        kwargs["backend"] = args.backend
    for option in ("max_steps", "time_limit"):
        if getattr(args, option) is not None:
            kwargs[option] = getattr(args, option)
    result = simulate(
        model, args.t_end, scenario=args.scenario, params=params, initial=initial,
        mode=args.mode, rtol=args.rtol, atol=args.atol, method=args.method,
        max_step=args.max_step, **kwargs,
    )
    if out is not None:
        result.save(out)
    jumps = len(result.jumps)
    print(f"status: {result.status.name}: {printable(result.message)}")
    print(f"events: {len(result.events)} ({jumps} jumps)")
    final = result.final
    state = ", ".join(f"{k}={v:.10g}" for k, v in final.state.items())
    print(f"final: t={final.t:.10g} j={final.j} mode={printable(final.mode)} {state}")
    if result.zeno_time is not None:
        print(f"zeno_time: {result.zeno_time:.12g}")
    if args.out:
        print(f"wrote {args.out}")
    if result.status is Status.INTERRUPTED:
        return EXIT_INTERRUPTED
    return EXIT_OK if result.status.ok else EXIT_INCOMPLETE


def _cmd_graph(args: argparse.Namespace) -> int:
    if args.max_cycle_length < 1:
        raise _UsageError(f"--max-cycle-length must be at least 1 (got {args.max_cycle_length})")
    model = load_model(args.model)
    if args.check:
        report = check_mode_graph(model, scenarios=args.scenario,
                                  max_cycle_length=args.max_cycle_length)
        print(report)
        return EXIT_OK if report.ok else EXIT_FINDINGS
    text = to_dot(model)
    if args.out:
        replace_text(args.out, text)
        print(f"wrote {args.out}")
    else:
        print(text, end="")
    return EXIT_OK


def _cmd_schema(args: argparse.Namespace) -> int:
    text = json.dumps(model_json_schema(), indent=2) + "\n"
    if args.out:
        replace_text(args.out, text)
    else:
        print(text, end="")
    return EXIT_OK


def _parser() -> _Parser:
    parser = _Parser(prog="hybridlab", description="Model, simulate and verify hybrid automata.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    check = sub.add_parser("check", help="validate a model file and summarise it")
    check.add_argument("model")
    check.set_defaults(run=_cmd_check)

    sim = sub.add_parser("simulate", help="simulate a model")
    sim.add_argument("model")
    sim.add_argument("--scenario")
    sim.add_argument("--t-end", type=float, dest="t_end")
    sim.add_argument("--set", action="append", metavar="NAME=VALUE", help="parameter override")
    sim.add_argument("--init", action="append", metavar="NAME=VALUE",
                     help="initial state override")
    sim.add_argument("--mode", help="initial mode")
    sim.add_argument("--rtol", type=float)
    sim.add_argument("--atol", type=float)
    sim.add_argument("--method", choices=METHODS)
    sim.add_argument("--max-step", type=float, dest="max_step")
    sim.add_argument("--zeno", choices=("stop", "error"))
    sim.add_argument("--max-steps", type=int, dest="max_steps",
                     help="integrator steps before stopping with STEP_LIMIT (default 10000000)")
    sim.add_argument("--time-limit", type=float, dest="time_limit", metavar="SECONDS",
                     help="wall-clock seconds before stopping with TIME_LIMIT")
    sim.add_argument("--backend", choices=("auto", "compiled", "reference"),
                     help="simulation backend (default: compiled when numba is installed)")
    sim.add_argument("--out", help="write the result (.json, .csv or .npz)")
    sim.set_defaults(run=_cmd_simulate)

    graph = sub.add_parser("graph", help="print the mode graph in Graphviz DOT, or check it")
    graph.add_argument("model")
    graph.add_argument("--out", help="write the DOT text to this file")
    graph.add_argument("--check", action="store_true",
                       help="report dead modes, guards that never hold, zero-dwell cycles; "
                            "exit 4 on a warning or an error")
    graph.add_argument("--scenario", action="append", metavar="NAME",
                       help="with --check: check only this scenario's parameters (repeatable)")
    graph.add_argument("--max-cycle-length", type=int, default=8, dest="max_cycle_length",
                       help="with --check: longest cycle examined (default 8)")
    graph.set_defaults(run=_cmd_graph)

    add_identify_parser(sub)
    add_import_parser(sub)
    add_sweep_parser(sub)
    add_reach_parser(sub)

    schema = sub.add_parser("schema", help="print the JSON schema of model files")
    schema.add_argument("--out")
    schema.set_defaults(run=_cmd_schema)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    try:
        args = _parser().parse_args(argv)
        return int(args.run(args))
    except SystemExit as exc:  # argparse's own exits: --help, --version
        code = exc.code
        if code is None:
            return EXIT_OK
        if isinstance(code, int):
            return code
        print(code, file=sys.stderr)
        return EXIT_INTERNAL
    except _UsageError as exc:
        print(f"hybridlab: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except SimulationError as exc:  # the run could not go on (e.g. --zeno error): not a user error
        text = " ".join(str(exc).split())
        print(f"hybridlab: error: {text}", file=sys.stderr)
        return EXIT_INCOMPLETE
    except (ModelError, ValueError, TypeError, OSError, HybridlabError) as exc:
        text = " ".join(str(exc).split())
        print(f"hybridlab: error: {text}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("hybridlab: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - one line and a report, never a traceback
        report = _write_report(argv)
        where = f"the full report is in {report}" if report else "no report could be written"
        print(f"hybridlab: internal error ({type(exc).__name__}); please report it: {where}",
              file=sys.stderr)
        return EXIT_BUG


def _write_report(argv: Sequence[str] | None) -> str | None:
    """Write the traceback of the exception being handled to a new file; its path."""
    try:
        fd, path = tempfile.mkstemp(prefix="hybridlab-report-", suffix=".txt")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(f"hybridlab {sys.argv[1:] if argv is None else list(argv)!r}\n\n")
            fh.write(traceback.format_exc())
    except OSError:
        return None
    return path


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
