"""Trolley as components against the same model written as one automaton: stop-and-return.

``models/trolley.toml`` builds the trolley from four components (plant, sensors,
controller, manoeuvre logic); ``tests/data/trolley_flat.toml`` is the same model written
by hand as one flat automaton. Both are loaded and compiled once, then scenario
``default`` (the 12 s event-based stop-and-return of Fig. 13) is timed on each backend,
the two models alternating run by run, and the events are compared.

Run ``python benchmarks/trolley_components.py [--quick] [--repeat N] [--json FILE]``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from common import Report, run_main, time_calls

import hybridlab

__all__ = ["run"]

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"components": ROOT / "models" / "trolley.toml",
          "flat": ROOT / "tests" / "data" / "trolley_flat.toml"}
BACKENDS = ("compiled", "reference")


def _events(result: hybridlab.SimulationResult) -> list[tuple[float, str]]:
    return [(e.t, e.transition) for e in result.events]


def run(repeat: int) -> Report:
    """Time the stop-and-return of both models on each backend; compare their events."""
    compiled = {k: hybridlab.compile_model(hybridlab.load_model(p)) for k, p in MODELS.items()}
    report = Report("trolley_components", "the trolley as components against one automaton")
    rows = []
    for backend in BACKENDS:
        fns = [lambda c=c, b=backend: hybridlab.simulate(c, scenario="default", backend=b)
               for c in compiled.values()]
        (comp, comp_run), (flat, flat_run) = time_calls(fns, repeat=min(repeat, 5)
                                                        if backend == "reference" else repeat)
        a, b = _events(comp_run), _events(flat_run)
        dt = max((abs(x[0] - y[0]) for x, y in zip(a, b, strict=True)), default=0.0)
        same = len(a) == len(b) and [x[1] for x in a] == [y[1] for y in b]
        ratio = comp.median / flat.median
        rows.append([backend, f"{1e3 * comp.median:.2f}", f"{1e3 * flat.median:.2f}",
                     f"{ratio:.3f}", str(len(a)), "yes" if same else "NO", f"{dt:.1e}"])
        report.records.append({"backend": backend, "components": comp.as_dict(),
                               "flat": flat.as_dict(), "ratio_median": ratio,
                               "events": len(a), "same_names": same, "max_dt_s": dt})
    states = {k: (len(c.model.states), len(c.model.discrete)) for k, c in compiled.items()}
    report.records.append({"states": states, "modes": {k: len(c.model.modes)
                                                       for k, c in compiled.items()}})
    report.tables.append((
        "Stop-and-return, 12 s (median ms; ratio = components / flat, the models alternating)",
        ["backend", "components", "flat", "ratio", "events", "same names", "max|dt| [s]"], rows))
    report.tables.append((
        "States of each model",
        ["model", "integrated (continuous)", "discrete", "modes"],
        [[k, str(n), str(m), str(len(compiled[k].model.modes))]
         for k, (n, m) in states.items()]))
    return report


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
