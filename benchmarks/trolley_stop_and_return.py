"""Trolley stop and return: hybridlab (reference and compiled backends) against a plain scipy loop.

Scenario ``default`` of ``models/trolley.toml``: the event-based stop-and-return of
Fig. 13 (sensors 250 mm from the start, a_max = 1 m/s^2, v_max = 0.4 m/s), 12 s. The
cart accelerates, cruises until sensor 1 sees the rod, brakes, returns to the
recorded position and holds it while the pendulum's residual swing decays.

Run ``python benchmarks/trolley_stop_and_return.py [--quick] [--repeat N] [--json FILE]``; at most
five timed repetitions per configuration (each run takes up to seconds). How the
implementations are compared: ``trolley_bench.py``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from common import Report, run_main
from trolley_bench import run_job

__all__ = ["run"]


def run(repeat: int) -> Report:
    """Check, then time the job at every tolerance level."""
    return run_job("stop_and_return", repeat, "trolley_stop_and_return",
                   "12 s event-based stop-and-return (Fig. 13)")


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
