"""Trolley free drop: hybridlab (reference and compiled backends) against a plain scipy loop.

Scenario ``free_drop`` of ``models/trolley.toml``: the pendulum dropped from 90 deg
over the sensor pair while the controller holds the cart, 60 s. The pendulum crosses
the vertical 84 times; the sensors (fields of view +-4 deg) see 78 and 79 of the
swings; the cart, shaken by the pendulum, sticks and slips about 70 times on its
Coulomb friction; the pendulum's bearing sticks for good near 44 s.

Run ``python benchmarks/trolley_free_drop.py [--quick] [--repeat N] [--json FILE]``; at most
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
    return run_job("free_drop", repeat, "trolley_free_drop",
                   "60 s free drop (84 crossings, ~310 sensor edges, stick/slip)")


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(run, __doc__.splitlines()[0], argv)


if __name__ == "__main__":
    sys.exit(main())
