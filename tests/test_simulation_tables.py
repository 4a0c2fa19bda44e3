"""EventTable and SegmentTable: tuple behaviour, columns, pickling, and the compiled backend's
lazy tables against the eagerly built events and segments of the same kernel records."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import hybridlab
from hybridlab.ensemble import Count
from hybridlab.simulation import Event, Segment, SimulationResult, Status
from hybridlab.simulation.result import FinalState
from hybridlab.simulation.tables import EventTable, SegmentTable

NAMES = ("x", "v")
MODES = ("up", "down")
LABELS = ("flip", "flop", "sign(x)")
KINDS = ("jump", "crossing", "slide_start", "slide_end")
# t, j, label, source, target, kind, grazing, pre, post
ROWS = [
    (0.5, 1, 0, 0, 1, 0, False, (1.0, -2.0), (1.0, 2.0)),
    (0.75, 1, 2, 1, 1, 1, False, (0.0, 1.5), (0.0, 1.5)),
    (1.25, 2, 1, 1, 0, 0, True, (-0.5, 0.25), (-0.5, 0.0)),
    (2.0, 3, 0, 0, 1, 0, False, (3.0, -1.0), (3.0, 1.0)),
    (2.5, 3, 2, 1, 1, 2, False, (0.0, 0.0), (0.0, 0.0)),
]


def _table() -> EventTable:
    cols = list(zip(*ROWS, strict=True))
    return EventTable.from_columns(
        NAMES, t=np.array(cols[0]), j=np.array(cols[1]), transition=np.array(cols[2]),
        labels=LABELS, source=np.array(cols[3]), target=np.array(cols[4]), modes=MODES,
        kind=np.array(cols[5]), kinds=KINDS, grazing=np.array(cols[6]),
        pre=np.array(cols[7]), post=np.array(cols[8]))


def _eager() -> tuple[Event, ...]:
    return tuple(Event(t, j, LABELS[lab], MODES[src], MODES[tgt],
                       dict(zip(NAMES, pre, strict=True)), dict(zip(NAMES, post, strict=True)),
                       KINDS[kind], grazing)
                 for t, j, lab, src, tgt, kind, grazing, pre, post in ROWS)


@pytest.fixture(params=["records", "objects"])
def tables(request) -> tuple[EventTable, tuple[Event, ...]]:
    """The same five events as a table of columns and as a table of Event objects."""
    eager = _eager()
    if request.param == "records":
        return _table(), eager
    return EventTable.from_events(_eager(), NAMES), eager


def test_a_table_equals_the_tuple_of_its_events_both_ways(tables):
    table, eager = tables
    assert table == eager and eager == table and (table != eager) is False
    assert len(table) == 5 and bool(table) and not EventTable.from_events((), NAMES)
    assert table == _table() and table == EventTable.from_events(_eager(), NAMES)
    # any difference in any field, in length or in type makes them unequal
    changed = (*eager[:2], dataclasses.replace(eager[2], post={"x": -0.5, "v": 1e-300}),
               *eager[3:])
    assert table != changed and changed != table
    assert table != eager[:4] and table != (*eager, eager[0])
    assert table != list(eager) and list(eager) != table
    assert repr(table) == repr(eager)
    with pytest.raises(TypeError):  # as for the tuple: the events hold dicts
        hash(table)
    assert table + eager[:1] == (*eager, eager[0]) and eager[:1] + table == (eager[0], *eager)


def test_indexing_like_a_tuple_including_negative_and_numpy_indices(tables):
    table, eager = tables
    for i in range(-5, 5):
        assert table[i] == eager[i]
        assert table[i] is table[i % 5]  # made once, then kept
    assert table[np.int64(-2)] == eager[-2]
    for bad in (5, -6, 10**12):
        with pytest.raises(IndexError):
            table[bad]
    with pytest.raises(TypeError, match="integers or slices"):
        table["t"]
    with pytest.raises(TypeError):
        table[1.0]
    assert list(table) == list(eager) and list(reversed(table)) == list(reversed(eager))
    assert eager[3] in table and table.index(eager[3]) == 3 and table.count(eager[1]) == 1
    assert dataclasses.replace(eager[3], j=9) not in table


@pytest.mark.parametrize("s", [slice(None), slice(1, 4), slice(None, None, -1), slice(4, 1, -2),
                               slice(-3, None), slice(3, 1), slice(-100, 100, 2)])
def test_slices_are_tables_of_the_same_events(tables, s):
    table, eager = tables
    part = table[s]
    assert isinstance(part, EventTable)
    assert part == eager[s] and len(part) == len(eager[s])
    assert all(a is table[table.index(a)] for a in part)
    np.testing.assert_array_equal(part.t, table.t[s])
    np.testing.assert_array_equal(part.pre, table.pre[s])
    assert part.transition == table.transition[s] and part.kind == table.kind[s]
    assert part[::-1] == eager[s][::-1] and part[1:] == eager[s][1:]


def test_columns_are_every_events_field(tables):
    table, eager = tables
    np.testing.assert_array_equal(table.t, [e.t for e in eager])
    np.testing.assert_array_equal(table.j, [e.j for e in eager])
    assert table.j.dtype.kind == "i" and table.grazing.dtype == bool
    np.testing.assert_array_equal(table.grazing, [e.grazing for e in eager])
    np.testing.assert_array_equal(table.post, [[e.post[n] for n in NAMES] for e in eager])
    assert table.pre.shape == (5, 2) and table.state_names == NAMES
    assert table.transition == tuple(e.transition for e in eager)
    assert table.source == tuple(e.source for e in eager)
    assert table.target == tuple(e.target for e in eager)
    table.t[0] = 99.0  # a column is a copy
    assert table.t[0] == 0.5 and table[0].t == 0.5


def test_where_selects_by_text_columns(tables):
    table, eager = tables
    assert table.where(kind="jump") == tuple(e for e in eager if e.kind == "jump")
    assert table.where(transition=("flop", "sign(x)"), source="down") == eager[1:3] + eager[4:]
    assert table.where(transition="nothing") == () and len(table.where(kind=())) == 0
    assert table[::-1].where(kind="jump") == tuple(e for e in eager[::-1] if e.kind == "jump")
    with pytest.raises(ValueError, match="not one of its text columns"):
        table.where(t=0.5)


def test_counts_read_the_same_from_a_table_and_from_a_tuple(tables):
    table, eager = tables
    for count, expected in ((Count(("flip", "flop")), 3), (Count("flip", after="flop"), 1),
                            (Count("flip", after="flip"), 1), (Count("flip", after="x"), None)):
        jumps = table.where(kind="jump")
        assert count.evaluate(jumps) == count.evaluate(tuple(jumps)) == expected


def test_pickling_keeps_the_columns_not_the_made_events(tables):
    table, eager = tables
    before = pickle.dumps(table)
    assert table[1:3] == eager[1:3] and list(table) == list(eager)  # every event made
    after = pickle.dumps(table)
    assert len(after) == len(before)
    back = pickle.loads(after)
    assert type(back) is EventTable and back == eager and back[-1] == eager[-1]
    np.testing.assert_array_equal(back.pre, table.pre)
    part = pickle.loads(pickle.dumps(table[3:0:-1]))
    assert part == eager[3:0:-1] and part.kind == table.kind[3:0:-1]


class _Line:
    """The dense output of one step of ``y = (2 t, -t)`` (picklable, unlike a lambda)."""

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        return np.stack([2 * t, -t])


class _Steps:
    """Each segment's interpolants, one per step, as a backend hands them to a table."""

    def __init__(self, count):
        self.count = count

    def __getitem__(self, k):
        return tuple(_Line() for _ in range(self.count[k] - 1))


def _segments() -> tuple[SegmentTable, tuple[Segment, ...]]:
    times = np.array([0.0, 0.5, 1.0, 1.0, 1.5, 1.5, 2.0, 3.0])
    states = np.vstack([times * 2, -times])
    first, count = np.array([0, 3, 5]), np.array([3, 2, 3])
    table = SegmentTable.from_columns(mode=np.array([1, 0, 1]), modes=MODES,
                                      j=np.array([0, 1, 2]), times=times, states=states,
                                      first=first, count=count, interpolants=_Steps(count))
    eager = tuple(Segment(MODES[m], j, times[a:a + c], states[:, a:a + c], _Steps(count)[k])
                  for k, (m, j, a, c) in enumerate(zip((1, 0, 1), (0, 1, 2), first, count,
                                                       strict=True)))
    return table, eager


def test_segment_tables_slice_and_join_like_their_segments():
    table, eager = _segments()
    assert len(table) == 3 and table.mode == ("down", "up", "down")
    for i in range(-3, 3):
        seg = table[i]
        assert seg is table[i % 3]
        assert (seg.mode, seg.j, seg.t_start, seg.t_end) == (eager[i].mode, eager[i].j,
                                                             eager[i].t_start, eager[i].t_end)
        np.testing.assert_array_equal(seg.y, eager[i].y)
        assert len(seg.interpolants) == seg.t.size - 1
        np.testing.assert_array_equal(seg(seg.t_end - 0.25), [2 * seg.t_end - 0.5,
                                                              0.25 - seg.t_end])
    for s in (slice(None), slice(1, None), slice(None, None, -1), slice(0, 3, 2), slice(2, 2)):
        part = table[s]
        joined = eager[s]
        t = np.concatenate([e.t for e in joined]) if joined else np.empty(0)
        np.testing.assert_array_equal(part.t, t)
        assert part.y.shape == (2, t.size)
        np.testing.assert_array_equal(part.y[1], -t)
        np.testing.assert_array_equal(part.t_start, [e.t_start for e in joined])
        np.testing.assert_array_equal(part.t_end, [e.t_end for e in joined])
        np.testing.assert_array_equal(part.n_points, [e.t.size for e in joined])
        np.testing.assert_array_equal(part.j, [e.j for e in joined])
    table.t[:] = -1.0  # joined points are copies
    assert table[0].t[0] == 0.0
    back = pickle.loads(pickle.dumps(table[1:]))
    assert back.mode == ("up", "down") and back[-1].t.tolist() == [1.5, 2.0, 3.0]


def _result(events, segments) -> SimulationResult:
    return SimulationResult(Status.COMPLETED, "done", events, segments,
                            FinalState(3.0, 3, "down", {"x": 6.0, "v": -3.0}), NAMES)


def test_a_result_wraps_plain_sequences_and_its_views_read_the_tables():
    _, eager_segments = _segments()
    by_objects = _result(_eager(), eager_segments)
    by_columns = _result(_table(), _segments()[0])
    for result in (by_objects, by_columns):
        assert isinstance(result.events, EventTable) and isinstance(result.segments, SegmentTable)
        assert result.events == _eager()
        assert result.jumps == tuple(e for e in _eager() if e.kind == "jump")
        assert result.mode_trace() == [(0.0, 0, "down"), (1.0, 1, "up"), (1.5, 2, "down")]
        np.testing.assert_array_equal(result.j, [0, 0, 0, 1, 1, 2, 2, 2])
        assert result.modes == ["down"] * 3 + ["up"] * 2 + ["down"] * 3
        np.testing.assert_array_equal(result.t, [0.0, 0.5, 1.0, 1.0, 1.5, 1.5, 2.0, 3.0])
        assert result.mode_at(1.2) == "up" and result.mode_at(1.5, j=1) == "up"
        np.testing.assert_array_equal(result(np.array([0.5, 1.0, 3.0])),
                                      [[1.0, 2.0, 6.0], [-0.5, -1.0, -3.0]])
        with pytest.raises(ValueError, match=r"outside the simulated hybrid time \(0.0, 3.0\)"):
            result(3.5)
        with pytest.raises(ValueError, match=r"\(j=5\) is outside"):
            result(1.0, j=5)
    assert by_objects.as_dict() == by_columns.as_dict()


# ----- the compiled backend: lazy tables against the eager build of the same records ------

def _eager_from_records(compiled, prep, o, EV, PT, ST, SG, last):
    """Events and segments made one by one from the kernel's records (the former build)."""
    from hybridlab.simulation.compiled.backend import StepInterpolants
    from hybridlab.simulation.compiled.integrate import METHOD_CODES

    names, modes, n = compiled.state_names, prep.mode_names, len(compiled.state_names)
    events = []
    for row in EV:
        j, which, src, tgt, kind = (int(v) for v in row[1:6])
        label = prep.jump_labels[which] if kind == 0 else prep.switch_labels[src][which]
        events.append(Event(float(row[0]), j, label, modes[src], modes[tgt],
                            dict(zip(names, row[7:7 + n].tolist(), strict=True)),
                            dict(zip(names, row[7 + n:].tolist(), strict=True)),
                            KINDS[kind], bool(row[6])))
    segments = []
    for m, j, p0, npt, s0, nst in SG.tolist():
        segments.append(Segment(modes[m], j, PT[p0:p0 + npt, 0].copy(),
                                PT[p0:p0 + npt, 1:].T.copy(),
                                StepInterpolants(METHOD_CODES[o.method], n, ST[s0:s0 + nst])))
    t, x, m, j = last
    if not segments or segments[-1].t_end < t or segments[-1].j != j:
        segments.append(Segment(modes[m], j, np.array([t]), x[:, None].copy()))
    return tuple(events), tuple(segments)


# a switch event in the second mode, whose switches come after the first mode's three: its label
# is found only with the right offset into the run's label table
def _spy(monkeypatch, module, name):
    """Replace ``module.name`` by a wrapper that records each call's arguments; the list."""
    calls, original = [], getattr(module, name)

    def spy(*args):
        calls.append(args)
        return original(*args)

    monkeypatch.setattr(module, name, spy)
    return calls


_SWITCH_IN_MODE_B = """
name = "switch_in_mode_b"
states = { x = 1.0, y = 0.0, s = 0.0 }
[modes.a]
flow = { x = "-1", y = "sign(x - 5) + sign(x + 6) + sign(s - 9)", s = "1" }
[modes.b]
flow = { x = "-sign(x)", y = "sign(y - 1)", s = "1" }
[[transitions]]
name = "go"
source = "a"
target = "b"
guard = "s >= 0.5"
[initial]
mode = "a"
"""


@pytest.mark.parametrize(("name", "kw"), [
    ("thermostat", {"t_end": 30.0}),
    ("thermostat", {"t_end": 60.0, "max_events": 5}),  # ends on an event: a one-point segment
    ("bouncing_ball", {"scenario": "zeno"}),
    ("friction_oscillator", {"scenario": "default"}),
    ("trolley", {"scenario": "default", "t_end": 2.1}),  # jumps and switch events, 7 modes
    (_SWITCH_IN_MODE_B, {"t_end": 2.0}),
])
def test_compiled_tables_equal_the_eagerly_built_events_and_segments(models_dir, monkeypatch,
                                                                      name, kw):
    pytest.importorskip("numba")
    from hybridlab.simulation.compiled import backend

    seen = _spy(monkeypatch, backend, "_records")
    model = (hybridlab.model.loads_model(name) if "\n" in name
             else hybridlab.load_model(models_dir / f"{name}.toml"))
    result = hybridlab.simulate(model, backend="compiled", **kw)
    assert result.stats["backend"] == "compiled" and len(seen) == 1
    events, segments = _eager_from_records(*seen[0])
    assert len(events) > 0
    assert result.events == events and events == result.events
    assert result.jumps == tuple(e for e in events if e.kind == "jump")
    np.testing.assert_array_equal(result.events.t, [e.t for e in events])
    assert len(result.segments) == len(segments)
    grid = []
    for lazy, eager in zip(result.segments, segments, strict=True):
        assert (lazy.mode, lazy.j, type(lazy.j)) == (eager.mode, eager.j, type(eager.j))
        np.testing.assert_array_equal(lazy.t, eager.t)
        np.testing.assert_array_equal(lazy.y, eager.y)
        assert len(lazy.interpolants) == len(eager.interpolants)
        inner = np.linspace(eager.t_start, eager.t_end, 5)
        np.testing.assert_array_equal(lazy(inner), eager(inner))
        grid.append(inner[1:-1])
    np.testing.assert_array_equal(result.t, np.concatenate([s.t for s in segments]))
    np.testing.assert_array_equal(result.y, np.concatenate([s.y for s in segments], axis=1))
    np.testing.assert_array_equal(result.j, np.concatenate([np.full(s.t.size, s.j)
                                                            for s in segments]))
    assert result.modes == [s.mode for s in segments for _ in range(s.t.size)]
    assert result.mode_trace() == [(s.t_start, s.j, s.mode) for s in segments]
    # the whole result through a process boundary (as a sweep sends it)
    back = pickle.loads(pickle.dumps(dataclasses.replace(result, compiled=None)))
    assert back.events == events and back.as_dict() == result.as_dict()
    ts = np.concatenate(grid)
    np.testing.assert_array_equal(back(ts), result(ts))


def test_compiled_events_are_read_from_the_records_only_when_needed(models_dir, monkeypatch):
    pytest.importorskip("numba")
    from hybridlab.simulation.compiled import backend

    calls = _spy(monkeypatch, backend, "_event_columns")
    result = hybridlab.simulate(models_dir / "thermostat.toml", t_end=30.0, backend="compiled")
    result(np.linspace(0.0, 30.0, 7))
    assert len(result.events) == 10 and result.final.j == 10 and result.t.size
    assert calls == []  # states, segments, the final state and len need no event
    assert result.jumps.transition[:2] == ("turn_off", "turn_on")
    assert result.events[-1].t == result.events.t[-1] and len(result.events.pre) == 10
    assert len(calls) == 1
    back = pickle.loads(pickle.dumps(dataclasses.replace(result, compiled=None)))
    assert back.events == result.events and len(calls) == 1
    fresh = hybridlab.simulate(models_dir / "thermostat.toml", t_end=30.0, backend="compiled")
    assert pickle.loads(pickle.dumps(fresh.events)) == result.events  # resolved when pickled
