"""Simulation results: hybrid time, mode trace, event log, dense evaluation, export."""

from __future__ import annotations

import csv
import enum
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, TypedDict

import numpy as np

from hybridlab._files import replace_file, replace_text
from hybridlab.simulation.tables import Event, EventTable, Segment, SegmentTable

__all__ = ["Status", "Event", "Segment", "FinalState", "SimulationStats", "SimulationResult"]

#: the most samples a grid step may ask for (800 MB per state as float64)
_MOST_SAMPLES = 100_000_000


class Status(enum.Enum):
    """How a simulation ended; each value is an actionable explanation.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, max_events=1,
    ...                             backend="reference")
    >>> result.status.name, result.status.ok, Status.COMPLETED.ok
    ('MAX_EVENTS', False, True)
    >>> result.status.value
    'stopped after max_events events: raise max_events if this is expected'
    """

    COMPLETED = "reached t_end"
    ZENO = ("events accumulate in finite time (Zeno behaviour); the model has no solution past "
            "the accumulation point: regularise it (e.g. a rest mode entered below a velocity "
            "threshold) or shorten t_end")
    INVARIANT_VIOLATED = ("the state reached the boundary of its mode's invariant and no "
                          "transition was enabled there: add or widen a guard")
    MAX_EVENTS = "stopped after max_events events: raise max_events if this is expected"
    SOLVER_FAILED = ("the integrator failed: try a stiff method (Radau, BDF), looser tolerances, "
                     "or check the flow for singularities")
    STEP_LIMIT = ("stopped after max_steps integrator steps: raise max_steps if this is "
                  "expected, or check t_end and max_step")
    TIME_LIMIT = "stopped at the wall-clock limit time_limit: raise it if this is expected"
    INTERRUPTED = "interrupted (Ctrl-C): the result holds the run up to that point"

    @property
    def ok(self) -> bool:
        """True only for ``COMPLETED``."""
        return self is Status.COMPLETED


@dataclass(frozen=True)
class FinalState:
    """Where a simulation ended.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, backend="reference")
    >>> final = result.final
    >>> final.t, final.j, final.mode, round(final.state["h"], 6)
    (3.0, 1, 'fall', 5.493562)
    """

    t: float
    j: int
    mode: str
    state: Mapping[str, float]


class SimulationStats(TypedDict, total=False):
    """What :attr:`SimulationResult.stats` holds: the run's counters and which backend ran it
    (a run has the keys that apply to it).

    Examples
    --------
    >>> import hybridlab
    >>> stats = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0,
    ...                            backend="reference").stats
    >>> stats["backend"], stats["segments"], stats["events_located"]
    ('reference', 2, 2)
    >>> "fallback" in stats  # set only when the compiled backend could not run the model
    False
    """

    steps: int
    refinements: int
    events_located: int
    segments: int
    quiet_steps: int
    backend: str
    compiled_cache_hit: bool
    fallback: str
    handoff: str


@dataclass(frozen=True)
class SimulationResult:
    """The outcome of :func:`hybridlab.simulate`.

    Attributes
    ----------
    status : Status
        How the run ended; ``status.ok`` is ``True`` for a complete run.
    message : str
        What happened, specific to this run.
    events : EventTable
        The event log in order: a sequence of :class:`Event` that behaves like
        a tuple, with columns such as ``events.t`` (any sequence of events
        given here is wrapped in one).
    segments : SegmentTable
        The flow pieces, with dense interpolants (a tuple-like sequence of
        :class:`Segment`, likewise).
    final : FinalState
        Time, jump count, mode and state at the end.
    state_names : tuple of str
    zeno_time : float or None
        Estimated accumulation time when ``status`` is ``ZENO``.
    stats : SimulationStats
        Counters: steps, flow evaluations, event locations, refinements; and the
        backend that ran the run.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, backend="reference")
    >>> result.status.ok, [(round(t, 6), j, mode) for t, j, mode in result.mode_trace()]
    (True, [(0.0, 0, 'fall'), (1.427843, 1, 'fall')])
    >>> result(1.0)  # dense state (h, v) at t = 1: 10 - 9.81 / 2 and -9.81
    array([ 5.095, -9.81 ])
    >>> grid, states = result.sample(1.0)
    >>> grid.tolist(), states.shape
    ([0.0, 1.0, 2.0, 3.0], (2, 4))
    """

    status: Status
    message: str
    events: EventTable
    segments: SegmentTable
    final: FinalState
    state_names: tuple[str, ...]
    zeno_time: float | None = None
    stats: SimulationStats = field(default_factory=SimulationStats)
    parameters: Mapping[str, float] = field(default_factory=dict)
    compiled: Any = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.events, EventTable):
            object.__setattr__(self, "events",
                               EventTable.from_events(self.events, self.state_names))
        if not isinstance(self.segments, SegmentTable):
            object.__setattr__(self, "segments",
                               SegmentTable.from_segments(self.segments, len(self.state_names)))

    def observe(self, expressions: str | Sequence[str],
                t: float | Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """Evaluate model expressions (definitions included) along this result.

        Parameters
        ----------
        expressions : str or sequence of str
            E.g. ``"energy"`` or ``["x_ref - x", "F_in"]``; mode-local
            definitions are taken from each segment's mode.
        t : optional
            Times; by default every stored point (:attr:`t`).

        Returns
        -------
        numpy.ndarray
            Shape ``(k,)`` for one expression, ``(m, k)`` for several.
        """
        from hybridlab.simulation.observe import Observer

        single = isinstance(expressions, str)
        texts = [expressions] if isinstance(expressions, str) else list(expressions)
        values = Observer(self.compiled, texts).evaluate(self, t)
        if t is not None and np.ndim(t) == 0:
            values = values[:, 0]
        return values[0] if single else values

    # ----- views ---------------------------------------------------------------------------
    @property
    def jumps(self) -> EventTable:
        """Only the events where a transition fired (a table of the same event objects)."""
        return self.events.where(kind="jump")

    @property
    def t(self) -> np.ndarray:
        """Times of all stored points (integrator steps and both sides of every event)."""
        return self.segments.t

    @property
    def y(self) -> np.ndarray:
        """States at :attr:`t`, shape ``(n, k)``."""
        return self.segments.y

    @property
    def j(self) -> np.ndarray:
        """Jump counter at :attr:`t` (hybrid time is the pair ``(t, j)``)."""
        return np.repeat(self.segments.j, self.segments.n_points).astype(int, copy=False)

    @property
    def modes(self) -> list[str]:
        """Mode at each point of :attr:`t`."""
        segments = self.segments
        return [m for m, k in zip(segments.mode, segments.n_points.tolist(), strict=True)
                for _ in range(k)]

    def mode_trace(self) -> list[tuple[float, int, str]]:
        """``(t_start, j, mode)`` for every segment, in order."""
        segments = self.segments
        return list(zip(segments.t_start.tolist(), segments.j.tolist(), segments.mode,
                        strict=True))

    def state(self, name: str) -> np.ndarray:
        """The stored trajectory of one state, aligned with :attr:`t`.

        In a model built from components, a qualified name (``heater.on_time``) may be
        written without its component when no other component has that name.

        Examples
        --------
        >>> import hybridlab
        >>> rooms = hybridlab.simulate("models/two_rooms.toml", t_end=5.0, backend="reference")
        >>> bool((rooms.state("on_time") == rooms.state("heater.on_time")).all())
        True
        >>> rooms.state("T")
        Traceback (most recent call last):
        ...
        ValueError: 'T' is the state of several components; write one of: room1.T, room2.T
        """
        names = self.state_names
        if name not in names:
            from hybridlab.model.names import aliases, spellings  # the model layer's rules

            qualified = aliases(names).get(name)
            if qualified is None:
                same = spellings(name, names)
                raise ValueError(
                    f"{name!r} is the state of several components; write one of: "
                    f"{', '.join(same)}" if len(same) > 1 else
                    f"no state {name!r} in this result; the states are {', '.join(names)}")
            name = qualified
        return self.y[names.index(name)]

    def _segment_at(self, t: float, j: int | None) -> Segment:
        segments = self.segments
        starts, ends = segments.t_start, segments.t_end
        inside = (starts <= t) & (t <= ends)
        if j is not None:
            inside &= segments.j == j
        if not inside.any():
            span = (float(starts[0]), float(ends[-1])) if len(segments) else ()
            raise ValueError(f"t={t!r} (j={j!r}) is outside the simulated hybrid time {span}")
        return segments[int(np.flatnonzero(inside)[-1])]

    def __call__(self, t: float | Sequence[float] | np.ndarray, j: int | None = None) -> np.ndarray:
        """Dense state at time(s) ``t``; at a jump instant the post-jump state unless ``j``.

        Returns shape ``(n,)`` for a scalar ``t`` and ``(n, k)`` otherwise.
        """
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        if j is not None:
            out = np.column_stack([self._segment_at(float(tk), j)(float(tk)) for tk in ts])
            return out[:, 0] if np.ndim(t) == 0 else out
        which = self.segment_index(ts)
        out = np.empty((len(self.state_names), ts.size))
        bounds = np.flatnonzero(np.diff(which)) + 1
        for chunk in np.split(np.arange(ts.size), bounds):
            if chunk.size:
                out[:, chunk] = self.segments[which[chunk[0]]](ts[chunk]).reshape(
                    len(self.state_names), chunk.size)
        return out[:, 0] if np.ndim(t) == 0 else out

    def segment_index(self, t: np.ndarray) -> np.ndarray:
        """Index of the segment holding each time (the last one at a jump instant)."""
        starts, ends = self.segments.t_start, self.segments.t_end
        ts = np.asarray(t, dtype=float)
        which = np.searchsorted(starts, ts, side="right") - 1
        bad = (which < 0) | (ts > ends[np.clip(which, 0, None)])
        if np.any(bad):
            first = float(ts[np.argmax(bad)])
            span = (float(starts[0]), float(ends[-1]))
            raise ValueError(f"t={first!r} is outside the simulated hybrid time {span}")
        return which

    evaluate = __call__

    def mode_at(self, t: float, j: int | None = None) -> str:
        """The mode at time ``t`` (post-jump at a jump instant)."""
        if j is None:
            return self.segments[int(self.segment_index(np.array([float(t)]))[0])].mode
        return self._segment_at(float(t), j).mode

    def sample(self, dt: float | Sequence[float] | np.ndarray | None = None, *,
               t: Sequence[float] | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """States on a uniform grid of spacing ``dt``, or at the given times.

        Parameters
        ----------
        dt : float or array_like
            A number: the grid's step, from the start of the run to its final
            time (the final time included when it falls on the grid). An array:
            the times themselves, as ``t``.
        t : array_like, optional
            Times inside the run, in any order.

        Returns
        -------
        t : numpy.ndarray
            The times, shape ``(k,)``.
        x : numpy.ndarray
            The states there, shape ``(n, k)``, from the dense output. At a jump
            instant the value *after* the jump (after every jump of a cascade at
            that instant), as ``result(t)`` gives; ``result(t, j=k)`` gives the
            value with jump counter ``k``.

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0,
        ...                             backend="reference")
        >>> bounce = result.jumps[0].t
        >>> t, x = result.sample([0.0, bounce, 2.0])
        >>> x.round(4) + 0.0  # at the bounce, v after it: 0.8 * 14.0071
        array([[10.    ,  0.    ,  4.8057],
               [ 0.    , 11.2057,  5.5929]])
        """
        times = self._sample_times(dt, t)
        if times is None:
            raise TypeError("sample() needs a step dt or the times t")
        return times, self._points(times)[3]

    def _sample_times(self, dt: float | Sequence[float] | np.ndarray | None,
                      t: Sequence[float] | np.ndarray | None) -> np.ndarray | None:
        """The times of a sample: a grid of step ``dt``, the times ``dt`` or ``t`` (given as
        an array), or ``None`` (neither given: the stored points)."""
        if dt is not None and t is not None:
            raise TypeError("give either a step dt or the times t, not both")
        if dt is not None and np.ndim(dt) == 0:
            return self._grid(float(dt))  # type: ignore[arg-type]
        times = dt if dt is not None else t
        if times is None:
            return None
        ts = np.asarray(times, dtype=float)
        if ts.ndim != 1:
            raise ValueError(f"t must be 1-dimensional (got shape {ts.shape})")
        if not np.isfinite(ts).all():
            raise ValueError("t must hold finite times")
        return ts.copy()

    def _grid(self, dt: float) -> np.ndarray:
        if not (dt > 0 and np.isfinite(dt)):
            raise ValueError(f"dt must be a positive number (got {dt!r})")
        t0, t1 = (float(self.segments.t_start[0]) if len(self.segments) else self.final.t,
                  self.final.t)
        if (t1 - t0) / dt > _MOST_SAMPLES:
            raise ValueError(f"dt={dt!r} gives more than {_MOST_SAMPLES:,} samples from "
                             f"t={t0!r} to t={t1!r}: choose a larger dt")
        grid = np.arange(t0, t1 + 0.5 * dt, dt)
        return grid[grid <= t1]

    def _points(self, times: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray]:
        """``t, j, modes, y`` at ``times`` (post-jump at a jump instant), or at the stored
        points for ``None``."""
        if times is None:
            return self.t, self.j, self.modes, self.y
        which = self.segment_index(times) if times.size else np.empty(0, dtype=np.int64)
        segments = self.segments
        modes = segments.mode
        y = (segments.dense(which, times) if times.size
             else np.empty((len(self.state_names), 0)))
        return (times, segments.j[which].astype(int, copy=False),
                [modes[k] for k in which.tolist()], y)

    def __repr__(self) -> str:
        from hybridlab.simulation._summary import short_repr

        return short_repr(self)

    def summary(self) -> str:
        """A short text: status and its explanation, time reached, events per transition,
        final mode and state, backend and counters.

        Examples
        --------
        >>> import hybridlab
        >>> stopped = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0, max_events=1,
        ...                              backend="reference")
        >>> print(stopped.summary())
        status: MAX_EVENTS: 1 events logged by t = 1.4278431229...
          stopped after max_events events: raise max_events if this is expected
        reached: t 0.0 -> 1.42784312292..., j=1
        events: 1 (1 jump)
          bounce: 1 jump
        final: mode fall, h=..., v=...
        run: reference backend, 2 segments, 1 event (1 jump), ... steps, ...
        """
        from hybridlab.simulation._summary import summary

        return summary(self)

    def plot(self, states: str | Sequence[str] | None = None, ax: Any = None) -> Any:
        """Draw states over time (the ``plot`` extra: matplotlib).

        Each state is one line from the dense output, broken at every jump;
        when the run visits several modes each mode's time is shaded in its own
        colour; every event is a dotted vertical line. Nothing is shown: the
        figure is returned, to save or to show.

        Parameters
        ----------
        states : str or sequence of str, optional
            The states to draw (default: all).
        ax : matplotlib Axes, optional
            Draw into these axes (then they are returned) instead of a new figure.

        Returns
        -------
        matplotlib.figure.Figure, or the Axes given

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.simulate("models/bouncing_ball.toml", t_end=3.0,
        ...                             backend="reference")
        >>> fig = result.plot("h")
        >>> [line.get_label() for line in fig.axes[0].get_lines()]
        ['h']
        >>> fig.savefig("ball.png")  # doctest: +SKIP
        """
        from hybridlab.simulation._plot import plot

        return plot(self, states, ax)

    def to_pandas(self, dt: float | Sequence[float] | np.ndarray | None = None, *,
                  t: Sequence[float] | np.ndarray | None = None) -> Any:
        """The trajectory as a pandas DataFrame (the ``pandas`` extra).

        One row per sample, columns ``t, j, mode`` and one per state. Without
        ``dt`` or ``t`` the samples are the stored points (every integrator step
        and both sides of every event, as :attr:`t`); with them, the times
        :meth:`sample` takes (post-jump values, ``j`` and mode at a jump
        instant). The events are ``result.events.to_pandas()``.

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.simulate("models/thermostat.toml", t_end=8.0,
        ...                             backend="reference")
        >>> df = result.to_pandas(dt=2.0)
        >>> df.round(4)
             t  j  mode        T
        0  0.0  0  heat  20.0000
        1  2.0  1  cool  20.9164
        2  4.0  1  cool  18.9376
        3  6.0  2  heat  19.8769
        4  8.0  3  cool  20.9836
        >>> len(result.to_pandas()) == len(result.t)
        True
        """
        from hybridlab.simulation._frames import frame

        times, j, modes, y = self._points(self._sample_times(dt, t))
        return frame({"t": times, "j": j, "mode": modes}, self.state_names, ("", y))

    # ----- export --------------------------------------------------------------------------
    def as_dict(self, include_trajectory: bool = True) -> dict[str, Any]:
        """A JSON-ready mapping: status, events, final, and the stored trajectory."""
        data: dict[str, Any] = {
            "status": self.status.name,
            "message": self.message,
            "zeno_time": self.zeno_time,
            "state_names": list(self.state_names),
            "events": [e.as_dict() for e in self.events],
            "final": {"t": self.final.t, "j": self.final.j, "mode": self.final.mode,
                      "state": dict(self.final.state)},
            "stats": dict(self.stats),
        }
        if include_trajectory:
            t, j, modes, y = self._points(None)
            data["trajectory"] = {"t": t.tolist(), "j": j.tolist(), "mode": modes,
                                  **{n: y[i].tolist() for i, n in enumerate(self.state_names)}}
        return data

    def to_json(self, path: str | Path | None = None) -> str:
        """Write (or return) the JSON form."""
        text = json.dumps(self.as_dict(), indent=1)
        if path is not None:
            replace_text(path, text)
        return text

    def to_csv(self, path: str | Path, dt: float | Sequence[float] | np.ndarray | None = None,
               *, t: Sequence[float] | np.ndarray | None = None) -> None:
        """Write the trajectory as CSV with columns ``t, j, mode, <states>``.

        Without ``dt`` or ``t``: the stored points (both sides of every
        event). With them: the samples :meth:`sample` takes, e.g. a uniform
        grid of step ``dt`` (post-jump values at a jump instant).

        Examples
        --------
        >>> import hybridlab, pathlib, tempfile
        >>> result = hybridlab.simulate("models/thermostat.toml", t_end=8.0,
        ...                             backend="reference")
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
        >>> result.to_csv(path, dt=0.5)
        >>> path.read_text().splitlines()[:3]
        ['t,j,mode,T', '0.0,0,heat,20.0', '0.5,0,heat,20.97541150998...']
        """
        times, j, modes, y = self._points(self._sample_times(dt, t))

        def write(fh: IO[str]) -> None:
            writer = csv.writer(fh)
            writer.writerow(["t", "j", "mode", *self.state_names])
            for k, (tk, jk, mk) in enumerate(zip(times, j, modes, strict=True)):
                writer.writerow([repr(float(tk)), int(jk), mk, *(repr(float(v)) for v in y[:, k])])

        replace_file(path, write)

    def to_npz(self, path: str | Path) -> None:
        """Write arrays ``t, j, y, state_names, modes`` and the event log to an NPZ file
        (at ``path`` exactly: no suffix is added)."""
        events = self.events
        replace_file(path, lambda fh: np.savez(
            fh, t=self.t, j=self.j, y=self.y, state_names=np.array(self.state_names),
            modes=np.array(self.modes), status=np.array(self.status.name),
            event_t=np.array([e.t for e in events]), event_j=np.array([e.j for e in events]),
            event_transition=np.array([e.transition for e in events], dtype=str),
            event_pre=np.array([[e.pre[n] for n in self.state_names] for e in events],
                               dtype=float).reshape(len(events), len(self.state_names)),
            event_post=np.array([[e.post[n] for n in self.state_names] for e in events],
                                dtype=float).reshape(len(events), len(self.state_names)),
        ), binary=True)

    def save(self, path: str | Path, *, dt: float | None = None) -> None:
        """Write by suffix: ``.json``, ``.csv`` or ``.npz``; ``dt`` (CSV only) samples a
        uniform grid, as :meth:`to_csv`."""
        suffix = Path(path).suffix.lower()
        writers: dict[str, Callable[[str | Path], object]] = {
            ".json": self.to_json, ".csv": self.to_csv, ".npz": self.to_npz}
        if suffix not in writers:
            raise ValueError(f"output file must end in .json, .csv or .npz (got {str(path)!r})")
        if dt is not None:
            if suffix != ".csv":
                raise ValueError(f"dt applies to a .csv file only (got {str(path)!r})")
            self.to_csv(path, dt)
            return
        writers[suffix](path)
