"""A run's events and flow segments, and the tuple-like tables that hold them.

:class:`EventTable` and :class:`SegmentTable` are read-only sequences that
behave like the tuples of :class:`Event` and :class:`Segment` they stand for
(``len``, indexing, negative indices, slicing, iteration, equality with a
tuple of the same objects, the same ``repr``, pickling). They keep the run
column by column, so a backend that produces records (the compiled kernel)
hands them over without making one Python object per event: an ``Event``,
with its ``pre`` and ``post`` dicts, or a ``Segment`` is made the first time
it is read and then kept. Columns (``events.t``, ``segments.t_start``, ...)
are answered from the records without making any. A table made from objects
(the reference engine) has the same interface.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

__all__ = ["Event", "EventTable", "Segment", "SegmentTable"]


@dataclass(frozen=True)
class Event:
    """One logged event.

    Attributes
    ----------
    t : float
        Event time.
    j : int
        Jump counter after the event (jumps increment it; switching-surface
        events of a discontinuous flow do not).
    transition : str
        Transition name, or the switching function for flow events.
    source, target : str
        Modes before and after.
    pre, post : mapping of str to float
        State before and after the event.
    kind : str
        ``"jump"`` (a transition fired), ``"crossing"`` (a discontinuity of the
        flow was crossed), ``"slide_start"`` or ``"slide_end"`` (Filippov sliding).
    grazing : bool
        The guard was reached tangentially.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, backend="reference")
    >>> bounce = result.events[0]
    >>> bounce.transition, bounce.kind, bounce.j, round(bounce.t, 6)
    ('bounce', 'jump', 1, 1.427843)
    >>> round(bounce.pre["v"], 6), round(bounce.post["v"], 6)  # v+ = -e v with e = 0.8
    (-14.007141, 11.205713)
    >>> sorted(bounce.as_dict())
    ['grazing', 'j', 'kind', 'post', 'pre', 'source', 't', 'target', 'transition']
    """

    t: float
    j: int
    transition: str
    source: str
    target: str
    pre: Mapping[str, float]
    post: Mapping[str, float]
    kind: str = "jump"
    grazing: bool = False

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready mapping."""
        return {"t": self.t, "j": self.j, "transition": self.transition, "source": self.source,
                "target": self.target, "kind": self.kind, "grazing": self.grazing,
                "pre": dict(self.pre), "post": dict(self.post)}


@dataclass(frozen=True)
class Segment:
    """A piece of flow in one mode between two jumps (or a solver restart).

    ``t`` and ``y`` hold the stored points (``y`` has shape ``(n, len(t))``);
    calling the segment evaluates its dense interpolant.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, backend="reference")
    >>> fall = result.segments[0]
    >>> fall.mode, fall.j, fall.t_start, round(fall.t_end, 6)
    ('fall', 0, 0.0, 1.427843)
    >>> fall(0.5)  # h = 10 - 9.81 * 0.5**2 / 2, v = -9.81 * 0.5
    array([ 8.77375, -4.905  ])
    """

    mode: str
    j: int
    t: np.ndarray
    y: np.ndarray
    interpolants: tuple[Any, ...] = field(repr=False, default=())

    @property
    def t_start(self) -> float:
        return float(self.t[0])

    @property
    def t_end(self) -> float:
        return float(self.t[-1])

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        """Dense state inside the segment; shape ``(n,)`` or ``(n, k)``."""
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((self.y.shape[0], ts.size))
        if len(self.interpolants) == 0 or len(self.t) < 2:
            out[:] = self.y[:, :1]
        else:
            idx = np.clip(np.searchsorted(self.t, ts, side="left") - 1, 0, len(self.t) - 2)
            at_steps = getattr(self.interpolants, "at_steps", None)
            if at_steps is not None:  # one vectorised call for every step
                out[:] = at_steps(idx, ts)
                return out[:, 0] if np.ndim(t) == 0 else out
            # one vectorised call per integrator step
            bounds = np.flatnonzero(np.diff(idx)) + 1
            for chunk in np.split(np.arange(ts.size), bounds):
                if chunk.size:
                    out[:, chunk] = self.interpolants[idx[chunk[0]]](ts[chunk]).reshape(
                        self.y.shape[0], chunk.size)
        return out[:, 0] if np.ndim(t) == 0 else out


def _new(cls: type, **fields: object) -> Any:
    """A frozen dataclass instance from its fields, without running ``__init__``.

    ``Event`` and ``Segment`` have no ``__post_init__``, so this is the object
    their ``__init__`` makes, at half the cost.
    """
    obj: Any = object.__new__(cls)
    obj.__dict__.update(fields)
    return obj


def _codes(values: Sequence[str]) -> tuple[np.ndarray, tuple[str, ...]]:
    """Integer codes of ``values`` into a table of the distinct values."""
    table = tuple(dict.fromkeys(values))
    index = {v: k for k, v in enumerate(table)}
    return np.array([index[v] for v in values], dtype=np.int64), table


class _BySegment(Protocol):
    """Indexed by segment number: a sequence, or any object with ``__getitem__`` (the
    compiled backend's per-segment dense output, made when read)."""

    def __getitem__(self, k: int, /) -> Any: ...


class _Store:
    """The rows of a table: objects made on demand, and columns.

    ``items(rows)`` are the objects of the given rows (all rows for ``None``),
    each made once and then kept; ``column(name)`` the named column over all
    rows (an array, or a tuple of str); ``codes(name)`` a text column as
    integer codes into a table of its values.
    """

    __slots__ = ()

    def __len__(self) -> int:
        raise NotImplementedError

    def items(self, rows: Sequence[int] | None) -> Sequence[Any]:
        raise NotImplementedError

    def item(self, r: int) -> Any:
        return self.items((r,))[0]

    def column(self, name: str) -> Any:
        raise NotImplementedError

    def codes(self, name: str) -> tuple[np.ndarray, tuple[str, ...]]:
        return _codes(self.column(name))


class _Records(_Store):
    """Rows given as columns; ``_make`` makes the objects of some rows in one pass."""

    __slots__ = ()
    _made: list[Any]

    def __len__(self) -> int:
        return len(self._made)

    def items(self, rows: Sequence[int] | None) -> Sequence[Any]:
        made = self._made
        if rows is None:
            rows = range(len(made))
        todo = [r for r in rows if made[r] is None]
        if todo:
            self._make(np.array(todo, dtype=np.int64))
        return [made[r] for r in rows]

    def item(self, r: int) -> Any:
        obj = self._made[r]
        return obj if obj is not None else self.items((r,))[0]

    def _make(self, rows: np.ndarray) -> None:
        raise NotImplementedError


class _Objects(_Store):
    """Rows given as objects (the reference engine's); columns computed once on demand."""

    __slots__ = ("objects", "n_states", "_columns")

    def __init__(self, objects: Sequence[Any], n_states: int) -> None:
        self.objects, self.n_states = tuple(objects), n_states
        self._columns: dict[str, Any] = {}

    def __len__(self) -> int:
        return len(self.objects)

    def items(self, rows: Sequence[int] | None) -> Sequence[Any]:
        objects = self.objects
        return objects if rows is None else [objects[r] for r in rows]

    def item(self, r: int) -> Any:
        return self.objects[r]

    def column(self, name: str) -> Any:
        if name not in self._columns:
            self._columns[name] = self._compute(name)
        return self._columns[name]

    def _compute(self, name: str) -> Any:
        raise NotImplementedError

    def __getstate__(self) -> tuple:
        return self.objects, self.n_states

    def __setstate__(self, state: tuple) -> None:
        self.objects, self.n_states = state
        self._columns = {}


class _Table(Sequence):
    """A read-only sequence over (some rows of) a store, behaving like a tuple of its items."""

    __slots__ = ("_store", "_rows")
    _TEXT_COLUMNS: tuple[str, ...] = ()

    def __init__(self, store: _Store, rows: np.ndarray | None = None) -> None:
        self._store = store
        self._rows = rows  # None: every row of the store, in order

    def __len__(self) -> int:
        return len(self._store) if self._rows is None else len(self._rows)

    def __getitem__(self, i):  # noqa: ANN001 - Sequence protocol
        if isinstance(i, slice):
            rows = np.arange(len(self._store)) if self._rows is None else self._rows
            return type(self)(self._store, rows[i])
        try:
            k = operator.index(i)
        except TypeError:
            raise TypeError(f"{type(self).__name__} indices must be integers or slices, "
                            f"not {type(i).__name__}") from None
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"{type(self).__name__} index out of range")
        k %= n
        return self._store.item(k if self._rows is None else int(self._rows[k]))

    def __iter__(self) -> Iterator[Any]:
        # every object at once: iterating usually reads them all, and one pass is cheaper
        return iter(self._store.items(None if self._rows is None else self._rows.tolist()))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, (_Table, tuple)):
            return NotImplemented
        if isinstance(other, _Table) and other._store is self._store and (
                other._rows is self._rows or (self._rows is not None and other._rows is not None
                                              and np.array_equal(self._rows, other._rows))):
            return True
        return len(self) == len(other) and all(a is b or a == b
                                               for a, b in zip(self, other, strict=True))

    def __hash__(self) -> int:
        return hash(tuple(self))

    def __repr__(self) -> str:
        return repr(tuple(self))

    def __add__(self, other: object) -> tuple:
        if not isinstance(other, (_Table, tuple)):
            return NotImplemented
        return (*self, *other)

    def __radd__(self, other: object) -> tuple:
        if not isinstance(other, tuple):
            return NotImplemented
        return (*other, *self)

    def _column(self, name: str) -> Any:
        col = self._store.column(name)
        if isinstance(col, tuple):
            return col if self._rows is None else tuple(col[r] for r in self._rows.tolist())
        return col.copy() if self._rows is None else col[self._rows]

    def where(self, **values: str | Collection[str]) -> Any:
        """The rows whose text columns take the given values, as a table of the same kind.

        Each keyword names a column and gives one value or a collection of
        values; rows must match every keyword. No object is made.

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.simulate("models/thermostat.toml", t_end=10.0)
        >>> result.events.transition
        ('turn_off', 'turn_on', 'turn_off')
        >>> ons = result.events.where(transition="turn_on")
        >>> len(ons), ons[0] is result.events[1], ons.t.round(3)
        (1, True, array([5.108]))
        """
        rows = np.arange(len(self._store)) if self._rows is None else self._rows
        for name, wanted in values.items():
            if name not in self._TEXT_COLUMNS:
                raise ValueError(f"{type(self).__name__}.where: {name!r} is not one of its text "
                                 f"columns ({', '.join(self._TEXT_COLUMNS)})")
            wanted = {wanted} if isinstance(wanted, str) else set(wanted)
            codes, table = self._store.codes(name)
            hit = np.array([v in wanted for v in table], dtype=bool)
            rows = rows[hit[codes[rows]]] if len(table) else rows[:0]
        return type(self)(self._store, rows)


class _EventRecords(_Records):
    """Events given as columns (or a function that returns them when first needed); an
    :class:`Event` is made when first read."""

    __slots__ = ("names", "_columns", "_made")
    _TEXT = {"transition": "labels", "source": "modes", "target": "modes", "kind": "kinds"}

    def __init__(self, names: tuple[str, ...], size: int,
                 columns: Mapping[str, Any] | Callable[[], Mapping[str, Any]]) -> None:
        self.names, self._columns = names, columns
        self._made: list[Event | None] = [None] * size

    @property
    def columns(self) -> Mapping[str, Any]:
        columns = self._columns
        if callable(columns):
            columns = self._columns = columns()
        return columns

    def _make(self, rows: np.ndarray) -> None:
        c, names = self.columns, self.names
        modes, labels, kinds = c["modes"], c["labels"], c["kinds"]
        made, new = self._made, object.__new__
        for r, t, j, label, src, tgt, kind, grazing, pre, post in zip(
                rows.tolist(), *(c[name][rows].tolist() for name in (
                    "t", "j", "transition", "source", "target", "kind", "grazing", "pre",
                    "post")), strict=True):
            event = new(Event)  # as _new, inlined: one per event
            event.__dict__.update(t=t, j=j, transition=labels[label], source=modes[src],
                                  target=modes[tgt], pre=dict(zip(names, pre, strict=True)),
                                  post=dict(zip(names, post, strict=True)), kind=kinds[kind],
                                  grazing=grazing)
            made[r] = event

    def column(self, name: str) -> Any:
        c = self.columns
        if name in self._TEXT:
            table = c[self._TEXT[name]]
            return tuple(table[k] for k in c[name].tolist())
        return c[name]

    def codes(self, name: str) -> tuple[np.ndarray, tuple[str, ...]]:
        c = self.columns
        return c[name], c[self._TEXT[name]]

    def __getstate__(self) -> tuple:  # the columns only: events are made again on demand
        return self.names, len(self._made), dict(self.columns)

    def __setstate__(self, state: tuple) -> None:
        type(self).__init__(self, *state)


class _EventObjects(_Objects):
    __slots__ = ("names",)

    def __init__(self, objects: Sequence[Event], names: tuple[str, ...]) -> None:
        super().__init__(objects, len(names))
        self.names = names

    def _compute(self, name: str) -> Any:
        events = self.objects
        if name in ("pre", "post"):
            return np.array([[getattr(e, name)[n] for n in self.names] for e in events],
                            dtype=float).reshape(len(events), self.n_states)
        values = [getattr(e, name) for e in events]
        if name in ("transition", "source", "target", "kind"):
            return tuple(values)
        dtype = {"t": float, "j": np.int64, "grazing": bool}[name]
        return np.array(values, dtype=dtype)

    def __getstate__(self) -> tuple:
        return self.objects, self.names

    def __setstate__(self, state: tuple) -> None:
        type(self).__init__(self, *state)


class EventTable(_Table):
    """A run's event log: a read-only sequence of :class:`Event` that behaves like a tuple.

    Indexing, negative indices, iteration, ``len``, ``in``, equality with a
    tuple of the same events, ``+`` and ``repr`` are those of the tuple; a
    slice is an ``EventTable`` again (of the same event objects). Columns give
    every event's field at once, straight from the records:
    ``events.t`` (times), ``events.j``, ``events.grazing`` and ``events.pre``,
    ``events.post`` (shape ``(k, n)``, states in :attr:`state_names` order)
    are arrays; ``events.transition``, ``source``, ``target`` and ``kind``
    are tuples of str.

    Examples
    --------
    >>> import hybridlab
    >>> events = hybridlab.simulate("models/bouncing_ball.toml", t_end=5.0).events
    >>> len(events), events[-1] is events[len(events) - 1]
    (2, True)
    >>> events.t.round(4)
    array([1.4278, 3.7124])
    >>> events[1:] == tuple(events)[1:], events.transition, events.pre.shape
    (True, ('bounce', 'bounce'), (2, 2))
    """

    __slots__ = ()
    _TEXT_COLUMNS = ("transition", "source", "target", "kind")
    _store: _EventRecords | _EventObjects

    @classmethod
    def from_events(cls, events: Sequence[Event], state_names: Sequence[str]) -> EventTable:
        """A table of the given events (the same objects)."""
        return cls(_EventObjects(events, tuple(state_names)))

    @classmethod
    def from_columns(cls, state_names: Sequence[str], *, t: np.ndarray, j: np.ndarray,
                     transition: np.ndarray, labels: Sequence[str], source: np.ndarray,
                     target: np.ndarray, modes: Sequence[str], kind: np.ndarray,
                     kinds: Sequence[str], grazing: np.ndarray, pre: np.ndarray,
                     post: np.ndarray) -> EventTable:
        """A table of events given column by column; each :class:`Event` is made when read.

        Parameters
        ----------
        state_names : sequence of str
        t : array of float, shape (k,)
        j : array of int, shape (k,)
        transition, source, target, kind : arrays of int, shape (k,)
            Codes into ``labels``, ``modes``, ``modes`` and ``kinds``.
        grazing : array of bool, shape (k,)
        pre, post : arrays of float, shape (k, n)
            States before and after, in ``state_names`` order.

        Examples
        --------
        >>> table = EventTable.from_columns(
        ...     ("x",), t=np.array([1.0]), j=np.array([1]), transition=np.array([0]),
        ...     labels=("reset",), source=np.array([0]), target=np.array([0]), modes=("on",),
        ...     kind=np.array([0]), kinds=("jump",), grazing=np.array([False]),
        ...     pre=np.array([[2.0]]), post=np.array([[0.0]]))
        >>> table[0]
        Event(t=1.0, j=1, transition='reset', source='on', target='on', pre={'x': 2.0}, \
post={'x': 0.0}, kind='jump', grazing=False)
        """
        columns = {"t": t, "j": j, "transition": transition, "labels": tuple(labels),
                   "source": source, "target": target, "modes": tuple(modes), "kind": kind,
                   "kinds": tuple(kinds), "grazing": grazing, "pre": pre, "post": post}
        return cls(_EventRecords(tuple(state_names), len(t), columns))

    @classmethod
    def deferred(cls, state_names: Sequence[str], size: int,
                 columns: Callable[[], Mapping[str, Any]]) -> EventTable:
        """A table of ``size`` events whose columns ``columns()`` returns when first needed.

        ``columns()`` returns the keyword arguments of :meth:`from_columns`
        (``labels``, ``modes`` and ``kinds`` as tuples); it is called at most
        once, by the first read of an event or a column, so a run whose events
        are never read never pays for them. ``len`` does not call it.

        Examples
        --------
        >>> calls = []
        >>> def columns():
        ...     calls.append(1)
        ...     return {"t": np.array([1.0]), "j": np.array([1]), "transition": np.array([0]),
        ...             "labels": ("reset",), "source": np.array([0]), "target": np.array([0]),
        ...             "modes": ("on",), "kind": np.array([0]), "kinds": ("jump",),
        ...             "grazing": np.array([False]), "pre": np.array([[2.0]]),
        ...             "post": np.array([[0.0]])}
        >>> table = EventTable.deferred(("x",), 1, columns)
        >>> len(table), len(calls)
        (1, 0)
        >>> table.t, table[0].post, len(calls)
        (array([1.]), {'x': 0.0}, 1)
        """
        return cls(_EventRecords(tuple(state_names), size, columns))

    @property
    def state_names(self) -> tuple[str, ...]:
        """The order of the states in :attr:`pre` and :attr:`post`."""
        return self._store.names

    @property
    def t(self) -> np.ndarray:
        """Event times."""
        return self._column("t")

    @property
    def j(self) -> np.ndarray:
        """Jump counters after the events."""
        return self._column("j")

    @property
    def transition(self) -> tuple[str, ...]:
        """Transition names (or switching functions)."""
        return self._column("transition")

    @property
    def source(self) -> tuple[str, ...]:
        """Modes before the events."""
        return self._column("source")

    @property
    def target(self) -> tuple[str, ...]:
        """Modes after the events."""
        return self._column("target")

    @property
    def kind(self) -> tuple[str, ...]:
        """Event kinds (see :class:`Event`)."""
        return self._column("kind")

    @property
    def grazing(self) -> np.ndarray:
        """Whether each guard was reached tangentially."""
        return self._column("grazing")

    @property
    def pre(self) -> np.ndarray:
        """States before the events, shape ``(k, n)``."""
        return self._column("pre")

    @property
    def post(self) -> np.ndarray:
        """States after the events, shape ``(k, n)``."""
        return self._column("post")

    def to_pandas(self) -> Any:
        """The events as a pandas DataFrame (the ``pandas`` extra), one row per event.

        Columns ``t, j, transition, source, target, kind, grazing``, then
        ``pre_<state>`` and ``post_<state>`` for every state in
        :attr:`state_names` order. Made from the columns, without an
        :class:`Event` object per event.

        Examples
        --------
        >>> import hybridlab
        >>> events = hybridlab.simulate("models/bouncing_ball.toml", t_end=5.0,
        ...                             backend="reference").events
        >>> df = events.to_pandas()
        >>> list(df.columns)
        ['t', 'j', 'transition', 'source', 'target', 'kind', 'grazing', 'pre_h', 'pre_v', \
'post_h', 'post_v']
        >>> df[["t", "post_v"]].round(4)
                t   post_v
        0  1.4278  11.2057
        1  3.7124   8.9646
        """
        from hybridlab.simulation._frames import frame

        fixed = {name: list(getattr(self, name)) if name in self._TEXT_COLUMNS
                 else getattr(self, name)
                 for name in ("t", "j", "transition", "source", "target", "kind", "grazing")}
        return frame(fixed, self.state_names, ("pre_", self.pre.T), ("post_", self.post.T))


class _SegmentRecords(_Records):
    """Segments given as columns over one array of points; a :class:`Segment` is made when read."""

    __slots__ = ("mode", "modes", "j", "times", "states", "first", "count", "interpolants",
                 "_made")

    def __init__(self, mode: np.ndarray, modes: tuple[str, ...], j: np.ndarray,
                 times: np.ndarray, states: np.ndarray, first: np.ndarray, count: np.ndarray,
                 interpolants: _BySegment | None) -> None:
        self.mode, self.modes, self.j = mode, modes, j
        self.times, self.states, self.first, self.count = times, states, first, count
        self.interpolants = interpolants
        self._made: list[Segment | None] = [None] * len(mode)

    def _make(self, rows: np.ndarray) -> None:
        times, states, modes, dense, made = (self.times, self.states, self.modes,
                                             self.interpolants, self._made)
        for r, mode, j, a, count in zip(rows.tolist(), self.mode[rows].tolist(),
                                        self.j[rows].tolist(), self.first[rows].tolist(),
                                        self.count[rows].tolist(), strict=True):
            made[r] = _new(Segment, mode=modes[mode], j=j, t=times[a:a + count],
                           y=states[:, a:a + count],
                           interpolants=() if dense is None else dense[r])

    def column(self, name: str) -> Any:
        if name == "mode":
            return tuple(self.modes[c] for c in self.mode.tolist())
        if name == "t_start":
            return self.times[self.first]
        if name == "t_end":
            return self.times[self.first + self.count - 1]
        return {"j": self.j, "n_points": self.count}[name]

    def codes(self, name: str) -> tuple[np.ndarray, tuple[str, ...]]:
        return self.mode, self.modes  # "mode" is the only text column

    def points(self, rows: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        first, count = (self.first, self.count) if rows is None else (
            self.first[rows], self.count[rows])
        if len(first) and np.array_equal(first[1:], first[:-1] + count[:-1]):
            a, b = int(first[0]), int(first[-1] + count[-1])  # consecutive: one slice
            return self.times[a:b].copy(), self.states[:, a:b].copy()
        pieces = [slice(a, a + c) for a, c in zip(first.tolist(), count.tolist(), strict=True)]
        if not pieces:
            return np.empty(0), np.empty((self.states.shape[0], 0))
        return (np.concatenate([self.times[s] for s in pieces]),
                np.concatenate([self.states[:, s] for s in pieces], axis=1))

    def dense(self, rows: np.ndarray, t: np.ndarray) -> np.ndarray | None:
        """States at ``t`` on segments ``rows`` in one evaluation, when the interpolants
        can (``None`` otherwise): what :meth:`Segment.__call__` gives, point by point."""
        at = getattr(self.interpolants, "at", None)
        stepped_of = getattr(self.interpolants, "stepped", None)
        if at is None or stepped_of is None:
            return None
        first, count = self.first[rows], self.count[rows]
        # the step of each time, as Segment.__call__ finds it in its own points
        g = np.clip(np.searchsorted(self.times, t, side="left"), first, first + count - 1)
        step = np.clip(g - first - 1, 0, np.maximum(count - 2, 0))
        out = self.states[:, first].copy()  # a segment of one point is constant
        stepped = (count >= 2) & stepped_of(rows)
        if stepped.any():
            out[:, stepped] = at(rows[stepped], step[stepped], t[stepped])
        return out

    def __getstate__(self) -> tuple:  # the columns only: segments are made again on demand
        return tuple(getattr(self, n) for n in self.__slots__[:-1])

    def __setstate__(self, state: tuple) -> None:
        type(self).__init__(self, *state)


class _SegmentObjects(_Objects):
    __slots__ = ()

    def _compute(self, name: str) -> Any:
        segments = self.objects
        if name == "mode":
            return tuple(s.mode for s in segments)
        dtype, value = {"j": (np.int64, lambda s: s.j),
                        "t_start": (float, lambda s: s.t_start),
                        "t_end": (float, lambda s: s.t_end),
                        "n_points": (np.int64, lambda s: s.t.size)}[name]
        return np.array([value(s) for s in segments], dtype=dtype)

    def points(self, rows: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        segments = self.items(None if rows is None else rows.tolist())
        if not segments:
            return np.empty(0), np.empty((self.n_states, 0))
        return (np.concatenate([s.t for s in segments]),
                np.concatenate([s.y for s in segments], axis=1))


class SegmentTable(_Table):
    """A run's flow segments: a read-only sequence of :class:`Segment` that behaves like a tuple.

    As :class:`EventTable`: tuple behaviour, slices are tables, each
    :class:`Segment` (and its dense interpolants) is made when first read.
    Per segment: :attr:`mode`, :attr:`j`, :attr:`t_start`, :attr:`t_end`,
    :attr:`n_points`; over all stored points of the table's segments, in
    order: :attr:`t` and :attr:`y`.

    Examples
    --------
    >>> import hybridlab
    >>> segments = hybridlab.simulate("models/bouncing_ball.toml", t_end=5.0).segments
    >>> len(segments), segments.mode[:2], segments.j.tolist()
    (3, ('fall', 'fall'), [0, 1, 2])
    >>> bool(segments.t_start[1] == segments[1].t_start == segments[0].t_end)
    True
    >>> segments.y.shape == (2, segments.n_points.sum()) == (2, segments.t.size)
    True
    """

    __slots__ = ()
    _TEXT_COLUMNS = ("mode",)
    _store: _SegmentRecords | _SegmentObjects

    @classmethod
    def from_segments(cls, segments: Sequence[Segment], n_states: int) -> SegmentTable:
        """A table of the given segments (the same objects) of a model with ``n_states`` states."""
        return cls(_SegmentObjects(segments, n_states))

    @classmethod
    def from_columns(cls, *, mode: np.ndarray, modes: Sequence[str], j: np.ndarray,
                     times: np.ndarray, states: np.ndarray, first: np.ndarray,
                     count: np.ndarray, interpolants: _BySegment | None = None
                     ) -> SegmentTable:
        """A table of segments given column by column; each :class:`Segment` is made when read.

        Parameters
        ----------
        mode : array of int, shape (k,)
            Codes into ``modes``.
        j : array of int, shape (k,)
        times : array of float, shape (m,)
            The stored points' times, shared by all segments.
        states : array of float, shape (n, m)
            The stored points' states.
        first, count : arrays of int, shape (k,)
            Each segment's points: ``times[first:first + count]``.
        interpolants : optional
            Indexed by segment, that segment's dense interpolants (one callable
            per step); read only when the segment is made. Default: none.

        Examples
        --------
        >>> table = SegmentTable.from_columns(
        ...     mode=np.array([0, 0]), modes=("on",), j=np.array([0, 1]),
        ...     times=np.array([0.0, 1.0, 1.0, 2.0]), states=np.array([[0.0, 1.0, 0.0, 1.0]]),
        ...     first=np.array([0, 2]), count=np.array([2, 2]))
        >>> table[-1]
        Segment(mode='on', j=1, t=array([1., 2.]), y=array([[0., 1.]]))
        >>> table.t_end, table.t
        (array([1., 2.]), array([0., 1., 1., 2.]))
        """
        return cls(_SegmentRecords(np.asarray(mode), tuple(modes), np.asarray(j), times, states,
                                   np.asarray(first), np.asarray(count), interpolants))

    def dense(self, segments: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The states at times ``t``, each on the dense output of the segment at the same
        position of ``segments`` (indices into this table); shape ``(n, len(t))``.

        The same numbers as calling each segment; for a run of the compiled backend one
        vectorised evaluation over all of them.

        Examples
        --------
        >>> import hybridlab
        >>> segments = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0).segments
        >>> x = segments.dense(np.array([0, 1]), np.array([0.5, 2.0]))
        >>> bool(np.allclose(x, np.column_stack([segments[0](0.5), segments[1](2.0)])))
        True
        """
        segments, t = np.asarray(segments, dtype=np.int64), np.asarray(t, dtype=float)
        rows = segments if self._rows is None else np.asarray(self._rows)[segments]
        fast = getattr(self._store, "dense", None)
        out = fast(rows, t) if fast is not None else None
        if out is not None:
            return out
        order = np.argsort(segments, kind="stable")
        result: np.ndarray | None = None
        for chunk in np.split(order, np.flatnonzero(np.diff(segments[order])) + 1):
            if chunk.size == 0:
                continue
            y = self[int(segments[chunk[0]])](t[chunk])
            if result is None:
                result = np.empty((y.shape[0], t.size))
            result[:, chunk] = y
        return result if result is not None else np.empty((0, 0))

    @property
    def mode(self) -> tuple[str, ...]:
        """Each segment's mode."""
        return self._column("mode")

    @property
    def j(self) -> np.ndarray:
        """Each segment's jump counter."""
        return self._column("j")

    @property
    def t_start(self) -> np.ndarray:
        """Each segment's first time."""
        return self._column("t_start")

    @property
    def t_end(self) -> np.ndarray:
        """Each segment's last time."""
        return self._column("t_end")

    @property
    def n_points(self) -> np.ndarray:
        """How many points each segment stores."""
        return self._column("n_points")

    @property
    def t(self) -> np.ndarray:
        """The times of all stored points of these segments, in order."""
        return self._store.points(self._rows)[0]

    @property
    def y(self) -> np.ndarray:
        """The states at :attr:`t`, shape ``(n, len(t))``."""
        return self._store.points(self._rows)[1]
