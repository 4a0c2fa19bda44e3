"""The trolley with its flags as integrated states against today's discrete variables.

Before discrete variables, ``models/trolley.toml`` integrated 18 states, 12 of them flags,
latched values and held samples with zero flow. Today's model (a network of components)
integrates the 6 physical states and keeps the 12 others as discrete variables. The
earlier file is read from the repository's history (``git show``, commit ``c3d3b45``, so
this script needs the git checkout); both are compiled once, then scenario ``default``
(the 12 s stop-and-return of Fig. 13) is timed on each backend, the two models
alternating run by run, and their event times compared.

Run ``python benchmarks/trolley_discrete.py [--quick] [--repeat N] [--json FILE]``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from common import Report, run_main, time_calls

import hybridlab

__all__ = ["run"]

ROOT = Path(__file__).resolve().parents[1]
BEFORE = "c3d3b45"
"""The last commit whose trolley integrated its flags (18 states)."""


def _before() -> hybridlab.Model:
    text = subprocess.run(["git", "show", f"{BEFORE}:models/trolley.toml"], cwd=ROOT,
                          check=True, capture_output=True, text=True).stdout
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "trolley.toml"
        path.write_text(text, encoding="utf-8")
        return hybridlab.load_model(path)


def run(repeat: int) -> Report:
    """Time the stop-and-return of both models on each backend; compare their events."""
    models = {"18 integrated": _before(),
              "6 + 12 discrete": hybridlab.load_model(ROOT / "models" / "trolley.toml")}
    compiled = {k: hybridlab.compile_model(m) for k, m in models.items()}
    report = Report("trolley_discrete", "the trolley's flags integrated against discrete")
    rows = []
    for backend in ("compiled", "reference"):
        fns = [lambda c=c, b=backend: hybridlab.simulate(c, scenario="default", backend=b)
               for c in compiled.values()]
        (old, old_run), (new, new_run) = time_calls(
            fns, repeat=min(repeat, 5) if backend == "reference" else repeat)
        a, b = [e.t for e in old_run.events], [e.t for e in new_run.events]
        dt = max((abs(x - y) for x, y in zip(a, b, strict=False)), default=0.0)
        ratio = old.median / new.median
        rows.append([backend, f"{1e3 * old.median:.2f}", f"{1e3 * new.median:.2f}",
                     f"{ratio:.2f}", f"{len(a)} / {len(b)}", f"{dt:.1e}"])
        report.records.append({"backend": backend, "before": old.as_dict(),
                               "after": new.as_dict(), "speedup": ratio,
                               "events": [len(a), len(b)], "max_dt_s": dt})
    report.tables.append((
        "Stop-and-return, 12 s (median ms; speed-up = 18 integrated / 6 + 12 discrete)",
        ["backend", "18 integrated", "6 + 12 discrete", "speed-up", "events", "max|dt| [s]"],
        rows))
    return report


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
