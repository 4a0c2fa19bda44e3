"""Input signals: tables (inline or CSV) and functions of time, breakpoints located as events."""

from __future__ import annotations

import pytest

import hybridlab
from hybridlab.errors import ModelError
from hybridlab.model.loader import dumps_model, load_model, loads_model
from hybridlab.model.signals import MAX_ROWS

#: x integrates a ramp-and-hold table, y a zero-order-hold table, z a function of time.
TRACK = """
name = "track"
parameters = { a = 0.5 }
states = { x = 0.0, y = 0.0, z = 0.0 }
modes.m.flow = { x = "u", y = "w", z = "f" }
initial.mode = "m"
[signals.u]
table = [[0, 0.0], [1, 2.0], [3, 2.0]]
[signals.w]
table = [[0.5, 1.0], [2.5, -1.0]]
interpolation = "previous"
[signals.f]
expr = "a*t"
"""


def _exact(t: float) -> tuple[float, float, float]:
    """x = integral of the ramp to 2 at t = 1 then 2; y of 1 then -1 from t = 2.5."""
    x = t * t if t <= 1 else 1 + 2 * (t - 1)
    y = t if t <= 2.5 else 2.5 - (t - 2.5)
    return x, y, 0.25 * t * t


def test_tables_and_functions_of_time_integrate_exactly_with_breakpoints_as_crossings():
    # the flow between breakpoints is polynomial: exact when no step straddles one
    result = hybridlab.simulate(loads_model(TRACK), t_end=4.0, backend="reference")
    assert result.status is hybridlab.Status.COMPLETED
    # a breakpoint is a crossing at its exact time; the one at the start and the
    # breakpoints where neither value nor slope changes are none
    assert [(e.t, e.kind, e.j) for e in result.events] == [(1.0, "crossing", 0),
                                                          (2.5, "crossing", 0)]
    assert [e.transition for e in result.events] == ["max(0, t - 1.0)", "sign(t - 2.5)"]
    for t in (0.7, 2.0, 4.0):
        assert result(t) == pytest.approx(_exact(t), abs=1e-9)


def test_a_signal_in_a_guard_fires_at_the_exact_instant(tmp_path):
    (tmp_path / "wind.csv").write_text("t,value\n0,0\n2,4\n")
    (tmp_path / "gust.toml").write_text("""
name = "gust"
states = { x = 0.0 }
modes.calm.flow.x = "wind"
modes.storm.flow.x = "0"
initial.mode = "calm"
signals.wind = { file = "wind.csv" }
[[transitions]]
name = "alarm"
source = "calm"
target = "storm"
guard = "wind >= 3"
""")
    model = load_model(tmp_path / "gust.toml")  # the CSV file next to the model file
    result = hybridlab.simulate(model, t_end=3.0, backend="reference")
    assert [(e.transition, e.kind) for e in result.events] == [("alarm", "jump")]
    assert result.events[0].t == pytest.approx(1.5, abs=1e-9)
    # the data lives in the model: it writes out and reads back without the file
    assert loads_model(dumps_model(model)) == model


def test_a_held_value_is_read_at_its_breakpoint_by_a_guard_and_a_reset():
    model = loads_model("""
name = "valve"
states = { x = 0.0 }
modes.shut.flow.x = "valve"
modes.open.flow.x = "0"
initial.mode = "shut"
signals.valve = { table = [[0, 0.0], [2, 1.0], [5, 0.0]], interpolation = "previous" }
[[transitions]]
name = "opened"
source = "shut"
target = "open"
guard = "valve >= 0.5"
reset = { x = "valve" }
""")
    result = hybridlab.simulate(model, t_end=3.0, backend="reference")
    crossing, jump = result.events
    assert (crossing.kind, jump.transition) == ("crossing", "opened")
    assert jump.t == pytest.approx(2.0, abs=1e-12)
    assert jump.post["x"] == 1.0


def test_reachability_encloses_a_run_with_signals():
    result = hybridlab.reach(loads_model(TRACK), t_end=2.0)
    low, high = result.sets[-1].bounds().T
    exact = _exact(2.0)
    assert all(lo - 1e-9 <= v <= hi + 1e-9 for lo, v, hi in zip(low, exact, high, strict=True))
    assert max(high - low) < 1e-3  # the breakpoints cost little width


def test_both_engines_agree():
    pytest.importorskip("numba")
    model = loads_model(TRACK)
    ref, comp = (hybridlab.simulate(model, t_end=4.0, backend=b)
                 for b in ("reference", "compiled"))
    assert [(e.t, e.transition) for e in comp.events] == [(e.t, e.transition)
                                                         for e in ref.events]
    assert comp(4.0) == pytest.approx(ref(4.0), abs=1e-9)


BASE = """
name = "m"
parameters = { k = 1.0 }
states = { x = 0.0 }
modes.m.flow.x = "u"
initial.mode = "m"
"""


@pytest.mark.parametrize(("signal", "expected"), [
    ('table = [[1, 0.0], [0, 1.0]]', "signals.u.table: times must increase strictly"),
    ('table = [[0, 0.0], [0, 1.0]]', "signals.u.table: times must increase strictly"),
    ('table = [[0, nan], [1, 1.0]]', "signals.u.table[0][1]: Input should be a finite number"),
    ('table = [[0, 0.0], [inf, 1.0]]', "signals.u.table[1][0]: Input should be a finite"),
    ('table = [[0, "a"], [1, 1.0]]', "signals.u.table[0][1]: Input should be a valid number"),
    ('table = []', "signals.u.table: a table needs at least one row"),
    (f'table = [{", ".join(f"[{i}, 0.0]" for i in range(MAX_ROWS + 1))}]',
     f"signals.u.table: a table has at most {MAX_ROWS} rows"),
    ('file = "nope.csv"', "signals.u.file: cannot read the table: No such file"),
    ('file = "bad.csv"', "signals.u.file: not a number (token '{dir}/bad.csv line 3: x')"),
    ('file = "back.csv"', "signals.u.file: times must increase strictly"),
    ('file = "big.csv"', "signals.u.file: cannot read the table: larger than"),
    ('table = [[0, 0.0]]\ninterpolation = "cubic"',
     "signals.u.interpolation: Input should be 'linear' or 'previous'"),
    ('expr = "x*t"', "signals.u.expr: unknown symbol (token 'x')"),
    ('table = [[0, 0.0]]\nexpr = "t"', "signals.u: a signal needs exactly one of table, file"),
])
def test_bad_signals_are_one_line_errors_naming_file_and_key(tmp_path, signal, expected):
    (tmp_path / "bad.csv").write_text("t,value\n0,1\n1,x\n")
    (tmp_path / "back.csv").write_text("1,1\n0,2\n")
    (tmp_path / "big.csv").write_text("0,1\n" * 20_000)
    path = tmp_path / "m.toml"
    path.write_text(f"{BASE}[signals.u]\n{signal}\n")
    with pytest.raises(ModelError) as info:
        load_model(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {expected.format(dir=tmp_path)}")


@pytest.mark.parametrize("clash", ["k", "x"])
def test_a_signal_name_may_not_clash_with_a_declared_name(clash):
    with pytest.raises(ModelError, match=f"signals.{clash}: name already declared"):
        loads_model(f'{BASE}signals.u = {{ expr = "t" }}\nsignals.{clash} = {{ expr = "t" }}\n')
