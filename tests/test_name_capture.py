"""No model name can capture a name the generated code relies on.

A parameter named ``e`` once turned ``exp(1)`` into the parameter's value in every
numpy function (flows, guards, resets, observers, reachability's point functions),
which made flowpipes unsound; ``arcsin`` or ``reduce`` broke the reference engine.
The oracle here is a *twin*: the same model with every name replaced by a plain one
(``n0, n1, ...``). The dangerous model must behave exactly like its twin on every
backend, in observers, in sweeps and in reach, and the closed forms pin both down.
"""

from __future__ import annotations

import io
import keyword
import math
import re
import tokenize

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hybridlab
from hybridlab.model.expressions import check_name
from hybridlab.simulation.compiled.codegen import generate
from hybridlab.simulation.observe import Observer
from hybridlab.symbolic.printing import PrintError, numpy_function

#: Names printers and generated code use: numpy, math, sympy, functools and builtins
#: spellings, lambdify's and the kernel's argument and temporary names.
DANGEROUS = (
    "e", "E", "I", "N", "S", "inf", "nan", "euler_gamma", "tau", "arcsin", "arccos", "arctan",
    "arctan2", "reduce", "functools", "numpy", "np", "math", "sympy", "sp", "builtins", "float",
    "int", "range", "sum", "len", "print", "exec", "eval", "compile", "open", "select", "where",
    "amin", "amax", "minimum", "maximum", "heaviside", "copysign", "fabs", "hypot", "x0", "x1",
    "x", "p", "f", "out", "op", "group", "sigma", "model", "box", "numba", "Dummy", "Symbol",
    "Float", "Integer", "Rational", "Abs", "Min", "Max", "Heaviside", "log10", "expm1",
    "array", "isnan", "self", "iv", "sign_", "v_x0", "c0", "a0", "g0", "r0", "generated",
    "lambdifygenerated", "Piecewise", "ITE", "true", "false", "nextafter", "gamma", "beta",
    "zeta", "LambertW", "Subs", "erf", "floor", "ceil", "mod", "power", "divide", "cbrt",
)
STATES = ("e", "x", "numpy", "out")
PARAMETERS = tuple(n for n in DANGEROUS if n not in STATES)


def _model_text(names: dict[str, str]) -> str:
    """A two-mode model over the dangerous names (or, through ``names``, their twins).

    Every parameter enters the flows, the guard, the reset and an invariant; the
    grammar's functions and ``pi`` appear next to them.
    """
    def n(name: str) -> str:
        return names[name]

    params = ", ".join(f"{n(q)} = {0.001 * (k + 1)!r}" for k, q in enumerate(PARAMETERS))
    drive = " + ".join(f"{n(q)}" for q in PARAMETERS)
    e, x, np_, out = (n(s) for s in STATES)
    flows = {
        e: f"-{e} + exp(1) + 0.1*({drive}) + asin(0.5)*{n('arcsin')}",
        x: f"-2*{x} + pi*{n('E')} + sqrt(2)*{n('reduce')} + sin({e})",
        np_: f"-{np_} + max({x}, {n('amax')}) + min({e}, 3)*{n('minimum')} + abs({out})",
        out: f"-{out} + atan2({n('I')}, 1) + cos({np_})*{n('inf')} - exp({n('nan')})",
    }
    flow_text = ", ".join(f'{k} = "{v}"' for k, v in flows.items())
    back = ", ".join(f'{k} = "{v.replace("exp(1)", "exp(-1)")}"' for k, v in flows.items())
    return f"""
name = "capture"
parameters = {{ {params} }}
states = {{ {e} = 1.0, {x} = 0.5, {np_} = 0.2, {out} = 0.1 }}

[modes.up]
flow = {{ {flow_text} }}
invariant = ["{e} <= 3 + {n('sum')}"]

[modes.down]
flow = {{ {back} }}

[[transitions]]
name = "switch"
source = "up"
target = "down"
guard = "{e} >= 2.5 + {n('len')} - exp(1)*{n('print')}"
reset = {{ {e} = "{e}*exp(1)/(exp(1) + {n('float')})", {x} = "{x} + {n('range')}" }}

[initial]
mode = "up"
"""


IDENTITY = {name: name for name in DANGEROUS}
TWIN = {name: f"n{k}" for k, name in enumerate(DANGEROUS)}


@pytest.fixture(scope="module")
def dangerous(tmp_path_factory) -> tuple[hybridlab.Model, hybridlab.Model]:
    folder = tmp_path_factory.mktemp("capture")
    (folder / "capture.toml").write_text(_model_text(IDENTITY), encoding="utf-8")
    (folder / "twin.toml").write_text(_model_text(TWIN), encoding="utf-8")
    return (hybridlab.load_model(folder / "capture.toml"),
            hybridlab.load_model(folder / "twin.toml"))


def test_every_name_is_declarable() -> None:
    for name in DANGEROUS:
        check_name(name)


@pytest.mark.parametrize("backend", ["reference", "auto"])
def test_dangerous_names_simulate_like_their_twin(dangerous, backend) -> None:
    model, twin = dangerous
    a = hybridlab.simulate(model, t_end=3.0, backend=backend, rtol=1e-10, atol=1e-12)
    b = hybridlab.simulate(twin, t_end=3.0, backend=backend, rtol=1e-10, atol=1e-12)
    assert a.status == b.status == hybridlab.Status.COMPLETED
    # switching-function crossings are named after their expression: rename those too
    renamed = [re.sub(r"[A-Za-z_]\w*", lambda m: TWIN.get(m.group(0), m.group(0)), ev.transition)
               for ev in a.events]
    assert renamed == [ev.transition for ev in b.events]
    assert "switch" in renamed
    np.testing.assert_allclose([ev.t for ev in a.events], [ev.t for ev in b.events], rtol=1e-9)
    final_a = np.array([a.final.state[s] for s in STATES])
    final_b = np.array([b.final.state[TWIN[s]] for s in STATES])
    np.testing.assert_allclose(final_a, final_b, rtol=1e-9)


def test_both_backends_agree_on_the_dangerous_model(dangerous) -> None:
    model, _ = dangerous
    ref = hybridlab.simulate(model, t_end=3.0, backend="reference", rtol=1e-10, atol=1e-12)
    fast = hybridlab.simulate(model, t_end=3.0, backend="auto", rtol=1e-10, atol=1e-12)
    assert [ev.transition for ev in ref.events] == [ev.transition for ev in fast.events]
    np.testing.assert_allclose([ev.t for ev in ref.events], [ev.t for ev in fast.events],
                               atol=1e-9)
    for s in STATES:
        assert ref.final.state[s] == pytest.approx(fast.final.state[s], rel=1e-8)


def test_a_parameter_named_e_is_not_eulers_number() -> None:
    """The closed form: ``x' = -x + exp(1)*e``, so ``x(t) = c + (x0 - c) exp(-t)``."""
    model = hybridlab.model_from_dict({
        "name": "euler", "parameters": {"e": 0.5, "arcsin": 2.0},
        "states": {"x": 1.0},
        "modes": {"run": {"flow": {"x": "-x + exp(1)*e + asin(1/arcsin)"}}},
        "initial": {"mode": "run"}})
    c = math.e * 0.5 + math.asin(0.5)
    for backend in ("reference", "auto"):
        r = hybridlab.simulate(model, t_end=1.0, backend=backend, rtol=1e-11, atol=1e-12)
        assert r.final.state["x"] == pytest.approx(c + (1 - c) * math.exp(-1), rel=1e-8)


@pytest.mark.parametrize("backend", ["reference", "auto"])
def test_observers_and_sweeps_read_names_not_builtins(dangerous, backend) -> None:
    model, twin = dangerous
    text = "exp(1)*e + pi*numpy + arcsin - reduce*E"
    twin_text = re.sub(r"\b(e|numpy|arcsin|reduce|E)\b", lambda m: TWIN[m.group(1)], text)
    run = hybridlab.simulate(model, t_end=1.0, backend=backend)
    value = Observer(hybridlab.compile_model(model), [text]).evaluate(run, [0.0])[0, 0]
    p = {q: 0.001 * (k + 1) for k, q in enumerate(PARAMETERS)}
    assert value == pytest.approx(math.e * 1.0 + math.pi * 0.2 + p["arcsin"] - p["reduce"] * p["E"])
    grid = {"arcsin": [0.1, 0.2]}
    twin_grid = {TWIN["arcsin"]: [0.1, 0.2]}
    a = hybridlab.sweep(model, grid=grid, t_end=1.0, observe={"v": text}, executor="serial",
                        backend=backend)
    b = hybridlab.sweep(twin, grid=twin_grid, t_end=1.0, observe={"v": twin_text},
                        executor="serial", backend=backend)
    np.testing.assert_allclose(a["v"], b["v"], rtol=1e-9)


def test_reach_encloses_the_true_flow_whatever_the_names() -> None:
    """Affine and nonlinear modes: the flowpipe contains the closed form, and equals the
    twin's. With ``e`` captured as Euler's number the sets missed the trajectories."""
    def model(e: str, a: str, kind: str) -> hybridlab.Model:
        flow = f"-x + exp(1)*{e} - {a}" if kind == "affine" else f"-x - 0.1*x**3 + exp(1)*{e}"
        return hybridlab.model_from_dict({
            "name": kind, "parameters": {e: 0.5, a: 0.25}, "states": {"x": 1.0},
            "modes": {"run": {"flow": {"x": flow}}}, "initial": {"mode": "run"}})

    for kind in ("affine", "nonlinear"):
        r = hybridlab.reach(model("e", "arcsin", kind), initial={"x": (0.9, 1.1)}, t_end=2.0,
                            step=0.01)
        twin = hybridlab.reach(model("n0", "n1", kind), initial={"x": (0.9, 1.1)}, t_end=2.0,
                               step=0.01)
        assert r.complete
        np.testing.assert_allclose(r.bounds["x"], twin.bounds["x"], rtol=1e-12)
        lo, hi = r.bounds["x"]
        for x0 in (0.9, 1.0, 1.1):
            sim = hybridlab.simulate(model("e", "arcsin", kind), t_end=2.0, initial={"x": x0},
                                     backend="reference", rtol=1e-10, atol=1e-12)
            xs = sim(np.linspace(0.0, 2.0, 201))[0]
            assert lo <= xs.min() and xs.max() <= hi


# ----- the printer itself ----------------------------------------------------------------
#: names a generated function may contain: keywords, its own argument and temporary
#: spellings, the modules it qualifies calls with, the kernel's fixed arguments and
#: interval module, and the builtins the scalar printer emits
_GENERATED = re.compile(r"_(a|c|g|r|b)\d+[lh]?|_v_[a-z]+\d+|_generated|_sign|_iv")
_FIXED = {"numpy", "math", "functools", "numba", "model", "box", "op", "group", "t", "x", "p",
          "sigma", "f", "out", "min", "max", "float", "abs", "import", "MODEL_SIGNATURE",
          "hybridlab", "simulation", "compiled", "interval_ops", "signatures", "return",
          "cache", "inline", "error_model", "v"}


def _free_names(text: str) -> set[str]:
    """Every NAME token of ``text`` that is not an attribute (after a dot)."""
    names, previous = set(), None
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.NAME and previous != ".":
            names.add(tok.string)
        if tok.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT):
            previous = tok.string
    return names


def _foreign(text: str) -> set[str]:
    return {n for n in _free_names(text)
            if not (keyword.iskeyword(n) or _GENERATED.fullmatch(n) or n in _FIXED)}


def test_no_model_name_reaches_the_kernel_source(dangerous) -> None:
    model, _ = dangerous
    source = generate(hybridlab.compile_model(model)).text
    assert _foreign(source) == set()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(DANGEROUS) | st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,8}",
                                                            fullmatch=True),
                min_size=3, max_size=3, unique=True))
def test_random_names_evaluate_like_plain_ones(names) -> None:
    import sympy as sp

    try:
        for name in names:
            check_name(name)
    except Exception:  # noqa: BLE001 - a name the grammar refuses is not a model name
        return
    a, b, c = (sp.Symbol(n, real=True) for n in names)
    exprs = [sp.exp(1) * a + sp.pi * b - sp.asin(c / 4), sp.Max(a, b, c) + sp.sign(a - b),
             sp.Min(a, 1) * sp.Abs(c)]
    values = np.array([0.7, -1.3, 2.1])
    expected = [math.e * 0.7 + math.pi * -1.3 - math.asin(2.1 / 4), 2.1 + 1.0, 0.7 * 2.1]
    for scalar in (False, True):
        f = numpy_function([[a, b, c]], exprs, scalar=scalar)
        np.testing.assert_allclose(np.array(f(values), dtype=float), expected, rtol=1e-14)
        assert _foreign(f.__doc__) == set()


def test_the_printer_refuses_names_it_was_not_given() -> None:
    import sympy as sp

    x, y = sp.symbols("x y", real=True)
    with pytest.raises(PrintError, match="'y'"):
        numpy_function([[x]], [x + y])
    with pytest.raises(PrintError, match="g"):
        numpy_function([[x]], [sp.Function("g")(x)])
