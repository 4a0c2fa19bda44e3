"""Targeted splitting of the initial set (``split="auto"``): where it cuts, what it keeps."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import hybridlab
from hybridlab.cli import main
from hybridlab.io import load_spaceex
from hybridlab.reachability import ReachOptions, reach

CUBIC = hybridlab.model_from_dict({
    "name": "cubic", "states": {"x": 1.0},
    "modes": {"run": {"flow": {"x": "-x**3"}}}, "initial": {"mode": "run"}})
WIDE = {"initial": {"x": (0.5, 2.0)}, "t_end": 1.0, "step": 0.1}


def _cubic_at(x0: np.ndarray, t: np.ndarray) -> np.ndarray:
    return x0 / np.sqrt(1.0 + 2.0 * x0 ** 2 * t)


def test_the_cubic_decay_is_cut_where_it_is_curved_and_every_solution_stays_inside():
    assert not reach(CUBIC, **WIDE).complete
    auto = reach(CUBIC, **WIDE, split="auto")
    assert auto.complete and auto.pieces == 5 and auto.options.split == "auto"
    # equal pieces need six: the lower half, where the flow is gentle, is cut once only
    assert not reach(CUBIC, **WIDE, split=5).complete
    lows = sorted({round(s.set.bounds()[0, 0], 6) for s in auto.sets if s.t[0] <= 0.0})
    assert len(lows) == 5
    t = np.linspace(0.0, 1.0, 41)
    for x0 in np.linspace(0.5, 2.0, 31):
        assert auto.covers(t, _cubic_at(x0, t)[:, None], "run").all(), x0


def test_the_piece_budget_ends_the_bisection_with_the_reason():
    cut = reach(CUBIC, **WIDE, split="auto", max_pieces=3)
    assert not cut.complete and cut.pieces == 2
    assert cut.incomplete_reasons[-1] == ("split='auto': 2 piece(s) still failed when the "
                                          "budget of max_pieces=3 analyses ran out")


def test_auto_split_pieces_on_threads_match_serial():
    serial = reach(CUBIC, **WIDE, split="auto")
    threads = reach(CUBIC, **WIDE, split="auto", executor="threads")
    assert threads.pieces == serial.pieces and threads.bounds == serial.bounds
    assert sorted(s.t for s in threads.sets) == sorted(s.t for s in serial.sets)


def _coupled_vdp(t, z):
    x1, y1, x2, y2, b = z
    return [y1, (1 - x1 ** 2) * y1 + b * (x2 - x1) - x1,
            y2, (1 - x2 ** 2) * y2 - b * (x2 - x1) - x2, 0.0]


def test_coupled_oscillators_are_cut_along_the_coupling_first(models_dir):
    # CVDP23: at the box's centre the oscillators are in phase and the coupling b(x2 - x1)
    # vanishes, so b acts only through products with x1 - x2: the Taylor model bends
    # along b most, though b's linear effect is nil
    cvdp = load_spaceex(models_dir / "spaceex" / "coupled_vanderpol.xml",
                        models_dir / "spaceex" / "coupled_vanderpol.cfg")
    kw = {**{k: v for k, v in cvdp.reach_kwargs().items() if k != "step"}, "t_end": 4.0,
          "step": 0.0175}  # the default step of the benchmark's horizon, T = 7
    whole = reach(cvdp.model, **kw, flowpipe="taylor")
    assert whole.too_wide and whole.split_direction is not None
    names = whole.state_names
    direction = np.abs(whole.split_direction) / np.max(np.abs(whole.split_direction))
    assert names[int(np.argmax(direction))] == "b" and np.sum(direction > 1e-12) == 1
    # its two halves along b get through, and hold the trajectories sampled from the box
    halves = reach(cvdp.model, **kw, flowpipe="taylor", split="auto", max_pieces=3)
    assert halves.complete and halves.pieces == 2
    lo = np.array([kw["initial"][n][0] for n in names])
    hi = np.array([kw["initial"][n][1] for n in names])
    rng = np.random.default_rng(7)
    starts = np.vstack([lo + (hi - lo) * rng.integers(0, 2, (8, len(names))),
                        lo + (hi - lo) * rng.uniform(size=(8, len(names)))])
    t = np.linspace(0.0, 4.0, 81)
    for z0 in starts:
        sol = solve_ivp(_coupled_vdp, (0.0, 4.0), z0, t_eval=t, rtol=1e-10, atol=1e-12)
        assert halves.covers(t, sol.y.T, "osc").all(), z0


def test_a_complete_flowpipe_too_wide_for_its_spec_is_bisected_before_the_step_is_halved(
        models_dir):
    # Van der Pol from the ARCH box over 3 s, linearised: the whole set completes with
    # y >= -2.721, its first unproved set fails at its step instants too (not only between
    # them), so the verdict bisects the set before halving the step; two halves prove it
    from hybridlab.verify import VerdictStatus, check_safety

    vdp = load_spaceex(models_dir / "spaceex" / "vanderpol.xml",
                       models_dir / "spaceex" / "vanderpol.cfg")
    kw = {**{k: v for k, v in vdp.reach_kwargs().items() if k != "step"}, "t_end": 3.0}
    assert reach(vdp.model, **kw).bounds["y"][0] < -2.7
    verdict = check_safety(vdp.model, safe="y >= -2.7", flowpipe="zonotope", **kw)
    assert verdict.status is VerdictStatus.SAFE, verdict.reason
    assert verdict.reason.endswith("(refined: the initial set bisected where its pieces "
                                   "failed, split='auto'; 2 pieces)")


def test_the_refinement_does_not_depend_on_how_far_the_quick_proof_got(models_dir,
                                                                       monkeypatch):
    # on a loaded machine the quick attempt's time cap can end it before its first unproved
    # set; the verdict then finds where that set fails by an attempt that ends there, and
    # bisects as it does on an idle machine
    from hybridlab.reachability import verdict as verdict_module
    from hybridlab.verify import VerdictStatus, check_safety

    monkeypatch.setattr(verdict_module, "_QUICK_PROOF_S", 0.0)
    vdp = load_spaceex(models_dir / "spaceex" / "vanderpol.xml",
                       models_dir / "spaceex" / "vanderpol.cfg")
    kw = {**{k: v for k, v in vdp.reach_kwargs().items() if k != "step"}, "t_end": 3.0}
    verdict = check_safety(vdp.model, safe="y >= -2.7", flowpipe="zonotope", **kw)
    assert verdict.status is VerdictStatus.SAFE, verdict.reason
    assert verdict.reason.endswith("(refined: the initial set bisected where its pieces "
                                   "failed, split='auto'; 2 pieces)")


@pytest.mark.parametrize(("changes", "message"), [
    ({"split": "half"}, "split must be a positive integer or 'auto'"),
    ({"max_pieces": 0}, "max_pieces must be a positive integer"),
    ({"taylor_order": 8}, "taylor_order must be an integer from 1 to 7"),
])
def test_bad_split_settings_are_one_line_errors(changes, message):
    with pytest.raises(ValueError, match=f"^{message}"):
        ReachOptions(**changes)


def test_the_command_line_bisects_with_split_auto(models_dir, capsys):
    args = ["reach", str(models_dir / "bouncing_ball.toml"), "--init", "h=9:10",
            "--t-end", "1", "--safe", "h >= -1", "--samples", "0", "--split", "auto"]
    assert main(args) == 0
    assert main([*args[:-1], "halves"]) == 2
    assert "--split: 'halves' is not" in capsys.readouterr().err
