"""Unread discrete outputs are left out of the analysis, soundly, and kept where observed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.reachability import reach
from hybridlab.reachability.slicing import unread_outputs
from hybridlab.reachability.system import build_system
from hybridlab.verify import check_safety

#: a follower behind a leader; a light barrier around p sets ``seen`` while the leader
#: is within w of it; nothing reads ``seen``
BARRIER = (Path(__file__).resolve().parents[1] / "models" / "barrier_follower.toml").read_text()
#: the same barrier also counting its passages (``count = count + 1`` reads itself)
COUNTING = (BARRIER
            .replace("seen = { value = false,", 'count = { value = 0, type = "int" }\n'
                                                "seen = { value = false,")
            .replace('reset = { seen = "0" }', 'reset = { seen = "0", count = "count + 1" }'))
INITIAL = {"x": (-0.05, 0.05)}


@pytest.fixture(scope="module")
def barrier():
    return hybridlab.compile_model(hybridlab.loads_model(COUNTING))


def test_a_counter_that_reads_itself_keeps_its_transition(barrier):
    """``count = count + 1`` is not a constant: ``count`` is followed, and so is ``off``;
    ``seen`` is then read by ``off``'s guard and followed too."""
    system = build_system(barrier, barrier.parameter_vector(), {}, {})
    assert unread_outputs(system).transitions == frozenset()
    observed = unread_outputs(system, observed=["count"])
    assert observed.transitions == frozenset()


def test_unread_flag_is_left_out_soundly_and_followed_where_observed(barrier):
    model = hybridlab.loads_model(BARRIER)
    sliced = reach(model, initial=INITIAL, t_end=2.0, step=0.01)
    assert sliced.complete, sliced.incomplete_reasons
    assert len(sliced.sets) == 200  # one flowpipe
    lo, hi = sliced.bounds["seen"]
    assert lo <= 0.0 and hi >= 1.0
    # followed, every passage of the barrier at an uncertain instant is a branch that may
    # or may not have jumped, and the joined crossings jump again and again
    kept = reach(model, initial=INITIAL, t_end=2.0, step=0.01, observed=("seen",),
                 max_jumps=6)
    assert not kept.complete and len(kept.sets) > 2 * len(sliced.sets)
    assert kept.bounds["y"][1] >= sliced.bounds["y"][1]
    # and exactly: seen is 0 until the leader can reach the barrier (x >= 0.9)
    early = reach(model, initial=INITIAL, t_end=0.8, step=0.01, observed=("seen",))
    assert all(abs(b) < 1e-9 for s in early.sets for b in s.bounds()[2])
    for x0 in (-0.05, 0.0, 0.05):
        sim = hybridlab.simulate(model, t_end=2.0, initial={"x": x0}, rtol=1e-10)
        grid = np.linspace(0.0, 2.0, 401)
        X, modes = sim(grid).T, [sim.mode_at(t) for t in grid]
        assert sliced.covers(grid, X, modes, tol=1e-7).all()
        assert [ev.transition for ev in sim.jumps] == ["on", "off"]


def test_a_spec_that_reads_the_flag_keeps_it_followed():
    """``seen - x <= 0.6`` holds before the barrier (seen is 0) but not over seen in
    [0, 1] at t = 0: check_safety follows what its specs read."""
    model = hybridlab.loads_model(BARRIER)
    verdict = check_safety(model, initial=INITIAL, t_end=0.8, safe="seen - x <= 0.6",
                           step=0.01)
    assert verdict.status.name == "SAFE", verdict.reason


def test_observed_names_are_checked(barrier):
    with pytest.raises(hybridlab.HybridlabError, match="observed: unknown name 'sen'"):
        reach(barrier, initial=INITIAL, t_end=0.1, observed=("sen",))
    with pytest.raises(ValueError, match="observed must be a sequence of names"):
        reach(barrier, initial=INITIAL, t_end=0.1, observed="seen")


def test_the_cli_takes_observed_names_and_refuses_unknown_ones(capsys):
    from hybridlab.cli import main
    base = ["reach", "models/sensor_follower.toml", "--init", "x=0:0.1", "--t-end", "1",
            "--safe", "y <= 10", "--samples", "0"]
    assert main([*base, "--observe", "e"]) == 0
    capsys.readouterr()
    assert main([*base, "--observe", "ee"]) == 2
    err = capsys.readouterr().err
    assert "observed: unknown name 'ee'" in err and err.count("\n") == 1
