"""``hybridlab identify``: parameters from measured data.

``add_parser(subparsers)`` adds::

    identify friction DATA.csv [--v-min V] [--out FILE.json] [--plot FILE.png]
    identify mass DATA.csv [--slope-tol TOL] [--out FILE.json] [--plot FILE.png]
    identify events MODEL DATA.csv --scenario NAME --fit NAME[,NAME...]
                    --sensor ID=RISING,FALLING --sensor ID=RISING,FALLING [...]
    identify targets MODEL TARGETS.toml|json --fit NAME[,NAME...] [...]

Each subcommand prints a table and sets ``run=<function(args) -> int>``; user errors
are raised as ``ValueError`` (or hybridlab errors) for the caller to print.
"""

from __future__ import annotations

import argparse
import contextlib
from typing import Any

from hybridlab.cli._args import EXIT_OK, finite_number, split_assignment
from hybridlab.cli._commands import HELP

__all__ = ["add_parser"]


def _finish(result: Any, args: argparse.Namespace) -> int:
    from hybridlab.identify._report import save_figure, write_json

    print(result.table())
    if args.out:
        write_json(args.out, result.as_dict())
        print(f"wrote {args.out}")
    if args.plot:
        save_figure(result.plot(), args.plot)
        print(f"wrote {args.plot}")
    return EXIT_OK


def _run_friction(args: argparse.Namespace) -> int:
    from hybridlab.identify.data import read_friction_csv
    from hybridlab.identify.friction import fit_friction

    return _finish(fit_friction(read_friction_csv(args.data), v_min=args.v_min), args)


def _run_mass(args: argparse.Namespace) -> int:
    from hybridlab.identify.data import read_frequency_csv
    from hybridlab.identify.frequency import fit_mass

    return _finish(fit_mass(read_frequency_csv(args.data), slope_tol=args.slope_tol,
                            window_decades=args.window), args)


def _pairs(items: list[str], option: str) -> dict[str, str]:
    out = {}
    for item in items or []:
        key, value = split_assignment(item, option)
        out[key] = value.strip()
    return out


def _numbers(items: list[str], option: str) -> dict[str, float]:
    return {k: finite_number(v, f"{option} {k}") for k, v in _pairs(items, option).items()}


def _run_events(args: argparse.Namespace) -> int:
    from hybridlab.identify.data import read_events_csv
    from hybridlab.identify.events import fit_events

    sensors = {}
    for key, value in _pairs(args.sensor, "--sensor").items():
        names = [n.strip() for n in value.split(",")]
        if len(names) != 2 or not all(names):
            raise ValueError(f"--sensor expects ID=RISING,FALLING (got {key}={value})")
        sensors[key] = (names[0], names[1])
    if len(sensors) < 2:
        raise ValueError("--sensor must be given for two sensors, e.g. "
                         "--sensor 1=on1,off1 --sensor 2=on2,off2")
    fit = [n.strip() for n in args.fit.split(",") if n.strip()]
    guess = _numbers(args.initial, "--initial")
    params = _numbers(args.param, "--param")
    distance: float | str | None = args.sensor_distance
    if distance is not None:
        with contextlib.suppress(ValueError):  # otherwise a parameter name
            distance = float(distance)
    result = fit_events(args.model, read_events_csv(args.data), fit=fit, sensors=sensors,
                        scenario=args.scenario, params=params, initial_guess=guess,
                        t_end=args.t_end, max_evaluations=args.max_evaluations,
                        method=args.method, sensor_distance=distance,
                        max_pair_gap=args.max_pair_gap)
    return _finish(result, args)


def _run_targets(args: argparse.Namespace) -> int:
    from hybridlab.identify.target_fit import fit_targets
    from hybridlab.identify.targets import read_targets

    fit = [n.strip() for n in args.fit.split(",") if n.strip()]
    guess = _numbers(args.initial, "--initial")
    params = _numbers(args.param, "--param")
    options = {"rtol": args.rtol} if args.rtol is not None else {}
    result = fit_targets(args.model, read_targets(args.targets), fit=fit, params=params,
                         initial_guess=guess, max_evaluations=args.max_evaluations,
                         method=args.method, simulation_options=options)
    return _finish(result, args)


def _outputs(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", metavar="FILE.json",
                        help="write the result as JSON; its 'parameters' maps names to values")
    parser.add_argument("--plot", metavar="FILE.png", help="plot the fit against the data "
                        "(needs matplotlib)")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``identify {friction,mass,events,targets}`` to an argparse ``subparsers`` object.

    Parameters
    ----------
    subparsers
        The object returned by :meth:`argparse.ArgumentParser.add_subparsers`.

    Returns
    -------
    argparse.ArgumentParser
        The ``identify`` parser.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="hybridlab")
    >>> _ = add_parser(parser.add_subparsers(dest="command"))
    >>> args = parser.parse_args(["identify", "friction", "runs.csv"])
    >>> args.run.__name__, args.data
    ('_run_friction', 'runs.csv')
    """
    identify: argparse.ArgumentParser = subparsers.add_parser(
        "identify", help=HELP["identify"],
        description="Identify parameters from measured data (CSV formats: "
                    "docs/identification.md).")
    sub = identify.add_subparsers(dest="identify_command", metavar="METHOD")
    sub.required = True

    friction = sub.add_parser("friction", help="c and d of F = c sign(v) + d v from "
                              "steady-state runs (columns velocity, force)")
    friction.add_argument("data", metavar="DATA.csv")
    friction.add_argument("--v-min", type=float, default=None,
                          help="exclude runs with |v| <= V (default: automatic rule)")
    _outputs(friction)
    friction.set_defaults(run=_run_friction)

    mass = sub.add_parser("mass", help="mass m from the -40 dB/dec region of a frequency "
                          "response (columns frequency_hz, magnitude_db[, phase_deg])")
    mass.add_argument("data", metavar="DATA.csv")
    mass.add_argument("--slope-tol", type=float, default=3.0,
                      help="accepted deviation from -40 dB/dec (default 3)")
    mass.add_argument("--window", type=float, default=0.3,
                      help="sliding-window width in decades (default 0.3)")
    _outputs(mass)
    mass.set_defaults(run=_run_mass)

    events = sub.add_parser("events", help="model parameters from sensor edges "
                            "(columns sensor, t, edge)")
    events.add_argument("model", metavar="MODEL")
    events.add_argument("data", metavar="DATA.csv")
    events.add_argument("--scenario", required=True, help="the experiment's scenario")
    events.add_argument("--fit", required=True, metavar="NAME[,NAME...]",
                        help="parameters to estimate")
    events.add_argument("--sensor", action="append", required=True,
                        metavar="ID=RISING,FALLING",
                        help="sensor id and the transitions of its edges (repeat; the first "
                             "two form the passages)")
    events.add_argument("--initial", action="append", metavar="NAME=VALUE",
                        help="start value of a fitted parameter")
    events.add_argument("--param", action="append", metavar="NAME=VALUE",
                        help="fixed parameter override")
    events.add_argument("--t-end", type=float, default=None,
                        help="end of the record (default: the scenario's t_end)")
    events.add_argument("--sensor-distance", default=None,
                        help="distance of the two sensors, or the parameter holding it")
    events.add_argument("--max-pair-gap", type=float, default=0.2,
                        help="largest time between the edges of a passage (s)")
    events.add_argument("--max-evaluations", type=int, default=30,
                        help="most simulations to run (default 30)")
    events.add_argument("--method", choices=("least_squares", "nelder-mead"),
                        default="least_squares")
    _outputs(events)
    events.set_defaults(run=_run_events)

    targets = sub.add_parser("targets", help="model parameters from summary quantities "
                             "(event counts, periods, values at events, step metrics)")
    targets.add_argument("model", metavar="MODEL")
    targets.add_argument("targets", metavar="TARGETS.toml|json",
                         help="a list 'targets' of tables (docs/identification.md)")
    targets.add_argument("--fit", required=True, metavar="NAME[,NAME...]",
                         help="parameters to estimate")
    targets.add_argument("--initial", action="append", metavar="NAME=VALUE",
                         help="start value of a fitted parameter")
    targets.add_argument("--param", action="append", metavar="NAME=VALUE",
                         help="fixed parameter override for every experiment")
    targets.add_argument("--rtol", type=float, default=None, help="integrator rtol")
    targets.add_argument("--max-evaluations", type=int, default=40,
                         help="most parameter points to simulate (default 40)")
    targets.add_argument("--method", choices=("least_squares", "nelder-mead"),
                         default="least_squares")
    _outputs(targets)
    targets.set_defaults(run=_run_targets)
    return identify

