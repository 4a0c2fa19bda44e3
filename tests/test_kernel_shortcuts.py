"""The exact shortcuts of the compiled kernel and the monitor slopes both backends share.

* states whose flow is identically zero in a mode are not combined by the integrator
  (``codegen.active_states``), with the same steps as integrating them;
* monitor slopes at the samples are the derivative of the dense output
  (``simulation.interpolant.dense_slope``; the kernel's copy in ``locate._batch``);
* an interval whose Hermite cubic provably stays above the tolerance skips the cubic's
  extrema (``locate._above``), without ever hiding a candidate;
* the hot loops run without numba's reference counting (``signatures.borrowing``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import DOP853, RK23, RK45, Radau

import hybridlab
from hybridlab.model.names import match_modes
from hybridlab.simulation.interpolant import dense_slope

numba = pytest.importorskip("numba")


def _spiral(t, y):
    return np.array([y[1], -y[0] - 0.3 * y[1] + np.sin(3.0 * t), 0.5 * y[0] ** 2])


@pytest.mark.parametrize("method", [RK23, RK45, DOP853])
def test_dense_slope_is_the_derivative_of_the_dense_output(method):
    solver = method(_spiral, 0.0, np.array([1.0, 0.0, 0.2]), 10.0, rtol=1e-6, atol=1e-9)
    for _ in range(5):
        solver.step()
        dense = solver.dense_output()
        tau = np.linspace(solver.t_old, solver.t, 7)
        slope = dense_slope(dense, tau)
        assert slope.shape == (3, tau.size)
        # the interpolant is a polynomial of degree <= 7 in t: an exact fit differentiates it
        nodes = np.linspace(solver.t_old, solver.t, 12)
        values = dense(nodes)
        for row in range(3):
            fit = np.polynomial.Polynomial.fit(nodes, values[row], 8)
            expected = fit.deriv()(tau)
            scale = np.max(np.abs(expected)) + 1e-12
            np.testing.assert_allclose(slope[row], expected, rtol=0, atol=1e-5 * scale)
        # at the step's ends the polynomial's slope is the flow there
        np.testing.assert_allclose(slope[:, -1], _spiral(solver.t, solver.y), rtol=1e-9,
                                   atol=1e-12)


def test_dense_slope_leaves_implicit_interpolants_to_the_flow():
    solver = Radau(_spiral, 0.0, np.array([1.0, 0.0, 0.2]), 1.0)
    solver.step()
    assert dense_slope(solver.dense_output(), np.array([0.5 * solver.t])) is None


def test_active_states_of_the_trolley(models_dir):
    from hybridlab.simulation.compiled.codegen import active_states

    compiled = hybridlab.compile_model(hybridlab.load_model(models_dir / "trolley.toml"))
    pointer, listed = active_states(compiled)
    names = compiled.state_names
    modes = list(compiled.modes)
    hold = modes.index(match_modes("hold", modes)[0])  # the product mode with logic.hold
    active = {names[i] for i in listed[pointer[hold]:pointer[hold + 1]]}
    # the mechanics, the velocity-loop integrator and the segment clock; the twelve
    # sampled, recorded and sensor states only change at jumps
    assert active == {"x", "v", "phi", "omega", "z", "tau"}


def test_a_state_read_by_a_switch_is_active_even_with_zero_flow(tmp_path):
    from hybridlab.simulation.compiled.codegen import active_states

    path = tmp_path / "m.toml"
    path.write_text('name = "m"\n[parameters]\nk = { value = 1.0 }\n'
                    '[states]\nx = { initial = 1.0 }\nb = { initial = 0.5, flow = "0" }\n'
                    'c = { initial = 0.0, flow = "0" }\n'
                    '[modes.a]\nflow = { x = "-k*sign(x - b)" }\n[initial]\nmode = "a"\n')
    compiled = hybridlab.compile_model(hybridlab.load_model(path))
    pointer, listed = active_states(compiled)
    assert [compiled.state_names[i] for i in listed[pointer[0]:pointer[1]]] == ["x", "b"]
    # and the run slides on x = b exactly as the reference does
    fast = hybridlab.simulate(compiled, t_end=2.0, backend="compiled")
    ref = hybridlab.simulate(compiled, t_end=2.0, backend="reference")
    assert [(e.kind, e.transition) for e in fast.events] == \
        [(e.kind, e.transition) for e in ref.events]
    assert abs(fast.final.state["x"] - 0.5) < 1e-9
    assert fast.final.state["c"] == 0.0 and fast.final.state["b"] == 0.5


def test_skipping_zero_flow_states_keeps_every_step(models_dir):
    """The kernel takes the reference's steps, and the skipped states stay bit for bit."""
    from hybridlab.simulation.compiled.codegen import active_states

    compiled = hybridlab.compile_model(hybridlab.load_model(models_dir / "trolley.toml"))
    fast = hybridlab.simulate(compiled, scenario="free_drop", t_end=0.5, backend="compiled")
    ref = hybridlab.simulate(compiled, scenario="free_drop", t_end=0.5, backend="reference")
    assert fast.stats["steps"] == ref.stats["steps"]
    pointer, listed = active_states(compiled)
    modes = list(compiled.modes)
    for segment in fast.segments:
        m = modes.index(segment.mode)
        skipped = sorted(set(range(len(compiled.state_names)))
                         - set(listed[pointer[m]:pointer[m + 1]]))
        assert len(skipped) == 12
        # through every step, and on the dense output between the stored points
        assert np.all(segment.y[skipped] == segment.y[skipped, :1])
        if segment.interpolants:
            mid = 0.5 * (segment.t[0] + segment.t[1])
            assert np.all(segment.interpolants[0](mid)[skipped] == segment.y[skipped, 0])


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=2000, deadline=None)
@given(h=st.floats(1e-6, 10.0), fa=finite, fb=finite, da=finite, db=finite,
       tol=st.sampled_from([0.0, 1e-12, 1e-3]))
def test_bernstein_skip_never_hides_a_candidate(h, fa, fb, da, db, tol):
    from hybridlab.simulation.compiled.locate import _above, _extremes

    if _above(h, fa, fb, da, db, tol):
        low, _, _, _ = _extremes(h, fa, fb, da, db)
        assert min(fa, fb, low) > tol
        # and on a fine grid of the cubic itself
        s = np.linspace(0.0, 1.0, 101)
        c1, c2 = h * da, 3.0 * (fb - fa) - h * (2.0 * da + db)
        c3 = 2.0 * (fa - fb) + h * (da + db)
        assert np.all(fa + s * (c1 + s * (c2 + s * c3)) > tol)


def test_bernstein_skip_takes_the_far_intervals():
    from hybridlab.simulation.compiled.locate import _above

    assert _above(0.1, 5.0, 4.0, -1.0, -1.0, 1e-12)      # far above zero: skipped
    assert not _above(0.1, 5.0, 0.5, -200.0, 1.0, 1e-12)  # may dip: the cubic is examined


def test_the_hot_kernel_functions_borrow_their_arrays():
    """The stages, the dense output, the sample loop, the root finders and the quiet-step
    bound are compiled without reference counting; the one callee that needs it says so
    (a callee compiled from a borrowing function would otherwise inherit the flag)."""
    from hybridlab.simulation.compiled import bounds, integrate, locate, sliding

    hot = [integrate._stages, integrate.rk_step, integrate._error_norm,
           integrate.dense_coefficients, locate._batch, locate._brentq, locate._locate,
           locate._fminbound, locate._search, sliding._flow_eq_sliding, sliding._sides,
           sliding._sdot, bounds.state_box, bounds.quiet_step]
    assert [f.py_func.__name__ for f in hot if f.targetoptions.get("_nrt") is not False] == []
    assert locate._exit_value.targetoptions.get("_nrt") is True


def test_without_numbas_refcount_option_the_kernel_compiles_as_plain_njit(monkeypatch):
    """``_nrt`` is an underscore option of numba: a numba without it gets plain ``njit``."""
    from hybridlab.simulation.compiled import signatures

    assert signatures._refcounting(False) == {"_nrt": False}
    monkeypatch.setattr(signatures, "CPUTargetOptions", type("Options", (), {}))
    assert signatures._refcounting(False) == {} == signatures._refcounting(True)


def test_borrowed_arrays_outlive_every_use(models_dir):
    """Runs that slide, exit sliding and locate events through the borrowing functions give
    the same events every time (a borrowed array freed too early would not)."""
    compiled = hybridlab.compile_model(hybridlab.load_model(models_dir / "trolley.toml"))
    runs = [hybridlab.simulate(compiled, backend="compiled", method=method)
            for method in ("DOP853", "RK45") for _ in range(10)]
    for first, again in ((runs[0], runs[1:10]), (runs[10], runs[11:])):
        events = [(e.t, e.transition, e.kind, tuple(e.post.values())) for e in first.events]
        assert len(events) > 50 and any(e.kind == "slide_end" for e in first.events)
        for other in again:
            assert [(e.t, e.transition, e.kind, tuple(e.post.values()))
                    for e in other.events] == events
