"""The integration-floor benchmark counts a run's steps by what slides in them."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import hybridlab

ROOT = Path(__file__).resolve().parents[1]
pytest.importorskip("numba")
sys.path.insert(0, str(ROOT / "benchmarks"))

import kernel_floor  # noqa: E402


def test_every_step_is_counted_once_by_its_sliding_switches():
    compiled = hybridlab.compile_model(hybridlab.load_model(ROOT / "models" / "trolley.toml"))
    result = hybridlab.simulate(compiled, scenario="default", backend="compiled",
                                **kernel_floor.TOL)
    counts = kernel_floor._steps_by_sliding(result, 2)
    assert sum(counts.values()) == result.stats["steps"]
    # the cart flies (nothing slides) and sticks (sign(v) slides) in the stop-and-return
    assert counts[(0, 0)] > 0
    assert counts[(1, 0)] > 0
    assert set(counts) <= {(0, 0), (1, 0), (0, 1), (1, 1)}
