"""The ARCH-COMP vehicle platoon (``models/spaceex/platoon.xml``): a time-varying input
carried through clock-guarded switches between two affine modes, checked against sampled
runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.linalg import expm

from hybridlab.io import load_spaceex
from hybridlab.verify import check_safety


def test_platoon_runs_with_switching_inputs_lie_in_the_flowpipes_across_the_switches():
    """The ARCH-COMP platoon (PLAD01): the leader's acceleration switching between random
    values of [-9, 1] at random instants, through the clock-guarded switches at 5, 10 and
    15 s; every sample of every run (exact per constant piece, by the matrix exponential of
    the augmented system) lies in the flowpipe of its mode, and the flowpipes prove the
    spacing errors >= -42 (BND42) as the published verdict says."""
    spaceex = Path(__file__).resolve().parents[1] / "models" / "spaceex"
    problem = load_spaceex(spaceex / "platoon.xml", spaceex / "platoon_plad01_bnd42.cfg")
    kwargs = problem.reach_kwargs()
    kwargs.pop("step", None)
    verdict = check_safety(problem.model, safe=problem.safe_specs(), **kwargs)
    assert verdict.status.name == "SAFE", verdict.reason
    result = verdict.reach
    assert result.complete and result.state_names[-1].startswith("t")
    connected = np.array([
        [0, 1, 0, 0, 0, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0, 0, 0, 0],
        [1.605, 4.868, -3.5754, -0.8198, 0.427, -0.045, -0.1942, 0.3626, -0.0946],
        [0, 0, 0, 0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, -1, 0, 0, 0],
        [0.8718, 3.814, -0.0754, 1.1936, 3.6258, -3.2396, -0.595, 0.1294, -0.0796],
        [0, 0, 0, 0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1, 0, 0, -1],
        [0.7132, 3.573, -0.0964, 0.8472, 3.2568, -0.0876, 1.2726, 3.072, -3.1356]])
    disconnected = connected.copy()
    disconnected[2, 3:] = 0.0
    disconnected[5, [0, 1, 2, 6, 7, 8]] = 0.0
    rng = np.random.default_rng(7)
    lowest, outside = 0.0, 0  # outside: samples moved 10 m back, not covered (the check bites)
    for run in range(12):
        x, t = np.zeros(9), 0.0
        while t < 20.0 - 1e-12:
            k = int(t // 5.0 + 1e-9)
            A, mode = (connected, "connected") if k % 2 == 0 else (disconnected, "disconnected")
            t1 = min(5.0 * (k + 1), t + float(rng.uniform(0.1, 2.0)))
            u = float(rng.choice([-9.0, 1.0])) if run % 2 else float(rng.uniform(-9.0, 1.0))
            aug = np.zeros((10, 10))  # (x, u): x' = A x + e_2 u, u' = 0
            aug[:9, :9], aug[1, 9] = A, 1.0
            tau = np.linspace(0.0, t1 - t, 40)[1:-1]
            states = np.array([(expm(aug * s) @ np.r_[x, u])[:9] for s in tau])
            clock = (t + tau) - 5.0 * k
            inside = result.covers(t + tau, np.column_stack([states, clock]), mode, tol=1e-9)
            assert inside.all(), (run, (t + tau)[~inside][0])
            if run == 0:
                shifted = np.column_stack([states + np.r_[-10.0, np.zeros(8)], clock])[::10]
                outside += int((~result.covers((t + tau)[::10], shifted, mode, tol=1e-9)).sum())
            lowest = min(lowest, float(states[:, [0, 3, 6]].min()))
            x, t = (expm(aug * (t1 - t)) @ np.r_[x, u])[:9], t1
    assert lowest < -15.0  # the inputs really drove the spacing errors down
    assert outside > 0
