"""A spec's margin along a run with many jumps, against dense brute force."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import hybridlab
from hybridlab.model.checks import TIME
from hybridlab.reachability.falsify import run_point
from hybridlab.reachability.margins import sample_trajectory, trajectory_margin
from hybridlab.reachability.spec import parse_spec
from hybridlab.simulation.problem import HybridProblem
from hybridlab.symbolic.functions import VectorFunction


def _dense(result, n_per_segment=400):
    """Every segment at many points: (t, states, segment index)."""
    ts, xs, ks = [], [], []
    for k, seg in enumerate(result.segments):
        t = np.linspace(seg.t[0], seg.t[-1], n_per_segment)
        ts.append(t)
        xs.append(seg(t).reshape(len(result.state_names), t.size))
        ks.append(np.full(t.size, k))
    return np.concatenate(ts), np.concatenate(xs, axis=1), np.concatenate(ks)


@pytest.mark.parametrize("backend", ["compiled", "reference"])
@pytest.mark.parametrize("text", ["v >= -13.5", "h <= 9.99", "h >= 0.0"])
def test_margin_and_first_violation_over_many_bounces(backend, text):
    if backend == "compiled":
        pytest.importorskip("numba")
    pb = HybridProblem.build("models/bouncing_ball.toml", t_end=25.0, params={"e": 0.95})
    result = run_point(pb, pb.x0, pb.p0, replace(pb.options, backend=backend))
    assert len(result.jumps) > 10
    spec, sym = parse_spec(text, pb.compiled), pb.compiled.symbolic
    fn = {mode: VectorFunction(rows, TIME, sym.states, sym.parameters, ())
          for mode, rows in spec.rows.items()}
    samples = sample_trajectory(result)
    m = trajectory_margin(result, spec, fn, pb.p0, samples)
    t, x, _ = _dense(result)
    values = spec.margin(fn["fall"].batch(t, x, pb.p0, np.empty(0)))
    # the lowest margin: never above the densest sampling (up to its grid), and reached
    assert m.margin <= values.min() + 1e-6 * (1 + abs(values.min()))
    assert m.margin >= values.min() - 1e-6 * (1 + abs(values.min()))
    bad = np.flatnonzero(spec.violated(values))
    if bad.size == 0:
        assert m.violation_t is None
    else:
        assert m.violation_t is not None
        assert m.violation_t <= t[bad[0]] + 1e-9
        assert m.violation_t >= t[bad[0]] - (t[1] - t[0]) * 2


def test_samples_share_one_dense_evaluation_across_specs():
    result = hybridlab.simulate("models/bouncing_ball.toml", t_end=5.0)
    samples = sample_trajectory(result)
    starts = samples.start
    assert starts[0] == 0 and starts[-1] == samples.t.size
    for k, seg in enumerate(result.segments):
        piece = slice(starts[k], starts[k + 1])
        np.testing.assert_array_equal(samples.x[:, piece], seg(samples.t[piece]))
        assert samples.t[piece][0] == seg.t[0] and samples.t[piece][-1] == seg.t[-1]
