"""Stick and slip as phases of the analysis (``hybridlab.reachability.phases``).

The friction oscillator (``m x'' = -k x - c sign(x')``, ``k = 4``, ``c = 0.5``) loses
``2 c / k`` of amplitude each half swing and sticks for good where ``|k x| <= c``, i.e.
``|x| <= 0.125``. From a box of states its velocity set lies across ``v = 0`` at every turn;
with the friction's sign free there, the flowpipe blows up. Split at the surface, each part
follows one side's flow, and the sets that reach the surface slide on it or cross.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import hybridlab
from hybridlab.reachability.options import ReachOptions

MODELS = Path(__file__).resolve().parents[1] / "models"
OSCILLATOR = MODELS / "friction_oscillator.toml"
BOX = {"x": (0.9, 1.1), "v": (-0.1, 0.1)}


@pytest.fixture(scope="module")
def phased():
    return hybridlab.reach(OSCILLATOR, initial=BOX, t_end=10.0)


def _hull_at(result, t):
    boxes = np.stack([s.bounds() for s in result.sets_at(t)])
    return boxes[:, :, 0].min(axis=0), boxes[:, :, 1].max(axis=0)


def test_the_oscillator_sticks_inside_the_band_the_closed_form_gives(phased):
    assert phased.complete
    for t in (8.0, 9.0, 10.0):
        lo, hi = _hull_at(phased, t)
        # stuck: v = 0, and |k x| <= c, the only states where friction can hold it
        assert lo[1] >= -1e-9 and hi[1] <= 1e-9
        assert lo[0] >= -0.125 and hi[0] <= 0.125
    assert {s.mode for s in phased.sets} == {"move"}  # phases are not modes of the model


def test_with_the_sign_free_the_same_flowpipe_blows_up():
    free = hybridlab.reach(OSCILLATOR, initial=BOX, t_end=10.0,
                           options=ReachOptions(sign_phases=False))
    lo, hi = _hull_at(free, 10.0)
    assert hi[0] - lo[0] > 1.0 and hi[1] - lo[1] > 1.0


def test_sampled_trajectories_lie_in_the_phased_flowpipe(phased):
    rng = np.random.default_rng(7)
    starts = [(x, v) for x in BOX["x"] for v in BOX["v"]]
    starts += [tuple(p) for p in rng.uniform([0.9, -0.1], [1.1, 0.1], size=(8, 2))]
    times = np.linspace(0.0, 10.0, 241)
    for x0, v0 in starts:
        run = hybridlab.simulate(OSCILLATOR, initial={"x": x0, "v": v0}, t_end=10.0,
                                 rtol=1e-10, atol=1e-12)
        states = np.array([run(t) for t in times])
        assert phased.covers(times, states, tol=1e-7).all(), (x0, v0)


def test_a_set_that_reaches_the_surface_from_one_side_is_not_split():
    # the relay x' = -sign(x) from x in [0.5, 1]: the states reach x = 0 one after another
    # and slide there; the surface rules hold the set, and no phase is taken
    kw = dict(initial={"x": (0.5, 1.0)}, t_end=2.0)
    phased = hybridlab.reach(MODELS / "relay_sliding.toml", **kw)
    free = hybridlab.reach(MODELS / "relay_sliding.toml", options=ReachOptions(sign_phases=False),
                           **kw)
    assert phased.complete and len(phased.sets) == len(free.sets)
    assert phased.bounds == free.bounds
    assert phased.bounds["x"][0] > -1e-9


def test_a_set_with_states_pushed_both_ways_is_not_split():
    # around the rest position the spring pushes some states forwards and some backwards
    # (k x changes sign over the set): a region where friction can stop them lies inside, so
    # the set keeps the surface rules and the result is the one with the sign free
    kw = dict(initial={"x": (-0.05, 0.05), "v": (-0.1, 0.1)}, t_end=1.0)
    phased = hybridlab.reach(OSCILLATOR, **kw)
    free = hybridlab.reach(OSCILLATOR, options=ReachOptions(sign_phases=False), **kw)
    assert phased.complete and len(phased.sets) == len(free.sets)
    assert phased.bounds == free.bounds


def test_with_every_sign_free_an_affine_flow_grows_as_its_inclusion_not_by_wrapping():
    # x'' = -4 x - 0.5 u, u in [-1, 1] at every instant: in the coordinates (x, v/2) the
    # input pushes the radius out at 0.25 |sin| per second at most, so from the box (radius
    # sqrt(2)) the largest |x| over 10 s is sqrt(2) + 0.25 (2/pi) 10 = 3.01. Stepped from set
    # to set and reduced at each step, the flowpipe wraps to 3.36; an affine mode whose signs
    # are all free keeps the sum of the input's steps apart from its turning sets (3.05)
    box = {"x": (-1.0, 1.0), "v": (-2.0, 2.0)}
    free = hybridlab.reach(OSCILLATOR, initial=box, t_end=10.0,
                           options=ReachOptions(sign_phases=False))
    assert free.complete
    assert max(-free.bounds["x"][0], free.bounds["x"][1]) < 3.1
    times = np.linspace(0.0, 10.0, 201)
    for x0 in box["x"]:
        for v0 in box["v"]:
            run = hybridlab.simulate(OSCILLATOR, initial={"x": x0, "v": v0}, t_end=10.0,
                                     rtol=1e-10, atol=1e-12)
            states = np.array([run(t) for t in times])
            assert free.covers(times, states, tol=1e-7).all(), (x0, v0)
