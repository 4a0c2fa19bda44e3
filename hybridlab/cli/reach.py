"""``hybridlab reach``: prove safety specs from an initial set, or find a counterexample.

``add_parser(subparsers)`` adds::

    reach MODEL --init NAME=LO:HI ... [--param NAME=LO:HI] [--input NAME=LO:HI]
          --t-end T --safe "SPEC" ... [--avoid NAME=LO:HI[,NAME=LO:HI...]]
          [--max-jumps N] [--scenario S] [--mode M] [--samples N] [--seed N]
          [--no-prove] [--out FILE.json]

and sets ``run=<function(args) -> int>`` returning 0 (SAFE), 1 (UNSAFE) or
3 (UNKNOWN). User errors are raised as ``ValueError`` (or hybridlab errors) for
the caller to print as one line with exit code 2.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hybridlab.cli._args import (
    EXIT_INCOMPLETE,
    EXIT_OK,
    finite_number,
    require_finite,
    split_assignment,
)
from hybridlab.cli._commands import HELP
from hybridlab.reachability.options import FalsifyOptions

if TYPE_CHECKING:
    from hybridlab.reachability.spec import Avoid
    from hybridlab.reachability.verdict import Verdict

__all__ = ["add_parser", "parse_ranges", "parse_intervals", "EXIT_CODES"]

#: Exit code of each verdict, by name; UNSAFE (a counterexample) fails like a failed test.
EXIT_CODES = {"SAFE": EXIT_OK, "UNSAFE": 1, "UNKNOWN": EXIT_INCOMPLETE}


def parse_ranges(items: Sequence[str] | None, option: str,
                 allow_point: bool = True) -> dict[str, float | tuple[float, float]]:
    """Parse ``NAME=LO:HI`` (an interval) or ``NAME=VALUE`` (a point) items.

    Examples
    --------
    >>> parse_ranges(["h=5:10", "v=-1"], "--init")
    {'h': (5.0, 10.0), 'v': -1.0}
    >>> parse_ranges(["h=10:5"], "--init")
    Traceback (most recent call last):
    ...
    ValueError: --init h: the interval 10:5 needs LO <= HI
    """
    out: dict[str, float | tuple[float, float]] = {}
    for item in items or ():
        form = "NAME=LO:HI or NAME=VALUE" if allow_point else "NAME=LO:HI"
        name, value = split_assignment(item, option, form=form, require_value=True)
        if name in out:
            raise ValueError(f"{option} {name}: given twice")
        interval = _interval(name, value, option)
        if interval is not None:
            out[name] = interval
        elif allow_point:
            out[name] = finite_number(value, f"{option} {name}")
        else:
            raise ValueError(f"{option} {name}: expects an interval LO:HI (got {value!r})")
    return out


def parse_intervals(items: Sequence[str] | None, option: str) -> dict[str, tuple[float, float]]:
    """Parse ``NAME=LO:HI`` items: :func:`parse_ranges` without points.

    Examples
    --------
    >>> parse_intervals(["u=-1:1"], "--input")
    {'u': (-1.0, 1.0)}
    >>> parse_intervals(["u=1"], "--input")
    Traceback (most recent call last):
    ...
    ValueError: --input u: expects an interval LO:HI (got '1')
    """
    out: dict[str, tuple[float, float]] = {}
    for item in items or ():
        name, value = split_assignment(item, option, form="NAME=LO:HI", require_value=True)
        if name in out:
            raise ValueError(f"{option} {name}: given twice")
        interval = _interval(name, value, option)
        if interval is None:
            raise ValueError(f"{option} {name}: expects an interval LO:HI (got {value!r})")
        out[name] = interval
    return out


def _interval(name: str, value: str, option: str) -> tuple[float, float] | None:
    """``value`` as an interval ``LO:HI``, or ``None`` when it has no colon."""
    lo_text, colon, hi_text = value.partition(":")
    if not colon:
        return None
    where = f"{option} {name}"
    lo, hi = finite_number(lo_text, where), finite_number(hi_text, where)
    if lo > hi:
        raise ValueError(f"{option} {name}: the interval {value.strip()} needs LO <= HI")
    return lo, hi


def _avoid(items: Sequence[str] | None) -> list[Avoid]:
    from hybridlab.reachability.spec import Avoid

    regions = []
    for item in items or ():
        parts = parse_intervals([p for p in item.split(",") if p.strip()], "--avoid")
        if not parts:
            raise ValueError(f"--avoid expects NAME=LO:HI[,NAME=LO:HI...] (got {item!r})")
        regions.append(Avoid(box=parts, name=f"avoid {item.strip()}"))
    return regions


def _print(verdict: Verdict) -> None:
    print(f"verdict: {verdict.status.name}: {verdict.reason}")
    if verdict.margin is not None:
        print(f"margin: {verdict.margin:.6g}")
    if verdict.reach is not None:
        r = verdict.reach
        print(f"reachable modes: {', '.join(sorted(r.reachable_modes))}")
        print("bounds: " + ", ".join(f"{k} in [{lo:.6g}, {hi:.6g}]"
                                     for k, (lo, hi) in r.bounds.items()))
    cx = verdict.counterexample
    if cx is not None:
        print("counterexample: from " + ", ".join(f"{k}={v:.10g}" for k, v in cx.initial.items()))
    print(f"time: {verdict.time_s:.3g} s")


DEFAULT_TIME_BUDGET = 1800.0
"""Seconds a ``reach`` command's analyses take at most unless ``--time-budget`` says
otherwise: every refinement of a verdict is bounded by its number of sets, but at the
default 200,000 sets a stiff nonlinear model's halvings could take hours (an 18-state cart
with a pendulum to 2.4 s: past 13 minutes and 3 GB with no answer); three times the slowest
documented command."""


def _run(args: argparse.Namespace) -> int:
    from hybridlab._files import replace_text
    from hybridlab.model.loader import load_model
    from hybridlab.reachability.verdict import check

    require_finite(args.t_end, "--t-end")
    if not args.safe and not args.avoid:
        raise ValueError("give at least one --safe SPEC or --avoid REGION")
    initial = parse_ranges(args.init, "--init")
    params = parse_ranges(args.param, "--param")
    inputs = parse_intervals(args.input, "--input")
    out = Path(args.out) if args.out else None
    if out is not None and out.suffix.lower() != ".json":
        raise ValueError(f"--out must end in .json (got {args.out!r})")
    if args.max_jumps is not None and args.max_jumps < 0:
        raise ValueError(f"--max-jumps must be >= 0 (got {args.max_jumps})")
    model = load_model(args.model)
    overrides = {} if args.max_jumps is None else {"max_jumps": args.max_jumps}
    for name in ("split", "step", "order", "clustering", "intersection", "max_sets",
                 "max_memory", "lift_clocks", "time_budget"):
        if getattr(args, name) is not None:
            overrides[name] = getattr(args, name)
    if args.observe:
        overrides["observed"] = tuple(args.observe)
    falsify_options = FalsifyOptions(samples=args.samples, seed=args.seed)
    verdict = check(model, initial=initial, t_end=args.t_end,
                    safe=[*args.safe, *_avoid(args.avoid)], mode=args.mode,
                    scenario=args.scenario, params=params, inputs=inputs,
                    falsify_options=falsify_options, prove=not args.no_prove,
                    executor=args.workers, **overrides)
    _print(verdict)
    if out is not None:
        replace_text(out, json.dumps(verdict.as_dict(), indent=1) + "\n")
        print(f"wrote {args.out}")
    return EXIT_CODES[verdict.status.name]


def _non_negative(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative")
    return value


def _seconds(text: str) -> float:
    """A positive finite number (a time or an order)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive finite number")
    return value


def _positive(text: str) -> int:
    value = _non_negative(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not positive")
    return value


def _split(text: str) -> int | str:
    return "auto" if text.strip() == "auto" else _positive(text)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add ``reach`` to the subparsers ``sub`` of the main command line; its parser.

    Examples
    --------
    >>> from hybridlab.cli._args import Parser
    >>> parser = Parser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
    >>> args = parser.parse_args(["reach", "models/bouncing_ball.toml", "--init", "h=9:10",
    ...                           "--t-end", "3", "--safe", "h <= 11", "--split", "2"])
    >>> args.init, args.t_end, args.safe, args.split, args.workers
    (['h=9:10'], 3.0, ['h <= 11'], 2, 1)
    """
    p: argparse.ArgumentParser = sub.add_parser(
        "reach", help=HELP["reach"],
        description="Exit codes: 0 SAFE, 1 UNSAFE, 3 UNKNOWN, 2 user error.")
    p.add_argument("model")
    p.add_argument("--init", action="append", metavar="NAME=LO:HI",
                   help="initial interval (or NAME=VALUE, a point) of a state; repeatable")
    p.add_argument("--param", action="append", metavar="NAME=LO:HI",
                   help="uncertain constant parameter (or NAME=VALUE); repeatable")
    p.add_argument("--input", action="append", metavar="NAME=LO:HI",
                   help="parameter varying in time within LO:HI; repeatable")
    p.add_argument("--t-end", type=float, dest="t_end", required=True)
    p.add_argument("--safe", action="append", default=[], metavar="SPEC",
                   help="'[MODE,...:] INEQUALITY [and ...]'; repeatable")
    p.add_argument("--avoid", action="append", metavar="NAME=LO:HI[,...]",
                   help="a box of states to avoid; repeatable")
    p.add_argument("--max-jumps", type=int, dest="max_jumps")
    p.add_argument("--split", type=_split, metavar="K|auto",
                   help="analyse K pieces along each uncertain direction of the initial set; "
                        "auto: bisect only the pieces that fail, where their set bends most")
    p.add_argument("--time-budget", type=_seconds, dest="time_budget", metavar="SECONDS",
                   default=DEFAULT_TIME_BUDGET,
                   help="stop the reachability analysis after this long: UNKNOWN with the "
                        "tightest bound so far (default %(default)g)")
    p.add_argument("--step", type=_seconds, metavar="DT",
                   help="flowpipe time step (default: the horizon / 400, or less for fast "
                        "oscillations)")
    p.add_argument("--order", type=_seconds, metavar="K",
                   help="zonotope order kept after each step (default 20)")
    p.add_argument("--clustering", choices=("auto", "box", "none", "sweep"),
                   help="how the step sets that hit a guard are joined (default box: all in one "
                        "box, in the state or principal axes; auto: into compact groups; "
                        "none: not at all; sweep: one zonotope that keeps the flowpipe's "
                        "correlations)")
    p.add_argument("--intersection", choices=("lp", "box"),
                   help="cut sets to a guard by LP (default) or by axis-aligned rows only")
    p.add_argument("--max-sets", type=_positive, dest="max_sets", metavar="N",
                   help="budget of flowpipe sets (default 200000)")
    p.add_argument("--max-memory", type=float, dest="max_memory", metavar="GIB",
                   help="budget of the kept flowpipe sets' memory in GiB, shared by all the "
                        "analyses of the verdict (default 2)")
    p.add_argument("--lift-clocks", action="store_true", default=None, dest="lift_clocks",
                   help="step modes polynomial in their clocks as affine chains over the "
                        "clocks' monomials (timed references)")
    p.add_argument("--observe", action="append", default=[], metavar="NAME",
                   help="a discrete variable to follow exactly although nothing reads it "
                        "(the specs' variables always are); repeatable")
    p.add_argument("--workers", type=_positive, default=1, metavar="N",
                   help="processes analysing the --split pieces (default 1: serially)")
    p.add_argument("--scenario")
    p.add_argument("--mode", help="initial mode")
    p.add_argument("--samples", type=_non_negative, default=FalsifyOptions.samples,
                   help="Latin-hypercube samples for falsification (default %(default)s)")
    p.add_argument("--seed", type=_non_negative, default=0, help="falsification seed")
    p.add_argument("--no-prove", action="store_true", dest="no_prove",
                   help="falsification only (no reachability): UNSAFE or UNKNOWN")
    p.add_argument("--out", help="write the verdict as JSON")
    p.set_defaults(run=_run)
    return p
