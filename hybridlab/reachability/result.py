"""Results of :func:`hybridlab.reach`: flowpipe sets and their summary."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

from hybridlab._files import replace_text
from hybridlab.model.expressions import as_expression, parse_expression
from hybridlab.reachability.options import ReachOptions
from hybridlab.reachability.rounding import SLACK
from hybridlab.reachability.sets import Zonotope
from hybridlab.symbolic.intervals import Interval, IntervalFunction

if TYPE_CHECKING:
    from hybridlab.model.checks import SymbolicMode

__all__ = ["ReachSet", "ReachResult", "merge_results"]


@dataclass(frozen=True, eq=False)
class _Context:
    """What :meth:`ReachSet.bound` needs to read an expression."""

    namespace: Mapping[str, sp.Expr]
    zsyms: tuple[sp.Symbol, ...]
    values: Mapping[sp.Symbol, float]
    inputs: Mapping[sp.Symbol, tuple[float, float]]
    t_index: int | None
    #: each mode's local definitions (a name defined per mode reads the set's mode's)
    modes: Mapping[str, SymbolicMode] = field(default_factory=dict)
    local_names: frozenset[str] = frozenset()
    #: compiled bound() expressions, per result (so thousands of sets parse each only once)
    cache: dict = field(default_factory=dict, repr=False, compare=False)

    def stacked(self, exprs: tuple[str | sp.Expr, ...], mode: str | None = None
                ) -> tuple[list[int], np.ndarray, np.ndarray, list[int]]:
        """``(rows, D, b, others)``: the indices of the expressions linear in the states,
        their directions ``a`` then ``-a`` stacked in ``D`` with offsets ``b``, and the
        indices of the others (cached, so a set's rows are stacked once per result and
        mode); a definition local to modes reads ``mode``'s."""
        key = ("stacked", mode, exprs)
        if key in self.cache:
            return self.cache[key]
        rows, others, A, b = [], [], [], []
        for k, expr in enumerate(exprs):
            compiled = self.compile(expr, mode)
            if compiled[0] == "linear":
                rows.append(k)
                A.append(compiled[1])
                b.append(compiled[2])
            else:
                others.append(k)
        D = np.vstack([np.array(A), -np.array(A)]) if rows else np.empty((0, len(self.zsyms)))
        out = (rows, D, np.array(b), others)
        self.cache[key] = out
        return out

    def compile(self, expr: str | sp.Expr, mode: str | None = None) -> tuple[Any, ...]:
        """``("linear", a, b)`` or ``("interval", f, uses_t)`` for :meth:`ReachSet.bound`;
        a definition local to modes reads ``mode``'s."""
        key = expr if isinstance(expr, str) else as_expression(expr)
        if key in self.cache:
            return self.cache[key]
        if (mode, key) in self.cache:
            return self.cache[(mode, key)]
        e: sp.Expr = parse_expression(expr, self.namespace) if isinstance(expr, str) else key
        local = any(str(s).startswith("_local_") for s in e.free_symbols)
        if local and mode is not None and mode in self.modes:
            e = self.modes[mode].scoped(e, self.local_names)
        e = e.xreplace(dict(self.values))
        t_sym = sp.Symbol("t", real=True)
        zs = self.zsyms
        free = e.free_symbols
        unknown = free - set(zs) - set(self.inputs) - {t_sym}
        if unknown:
            raise ValueError(f"bound(): unknown symbol {sorted(map(str, unknown))[0]!r} in {e}")
        linear = all(not sp.diff(e, z).free_symbols for z in zs) and not (
            free & (set(self.inputs) | ({t_sym} if self.t_index is None else set())))
        if linear:
            a = np.array([float(sp.diff(e, z)) for z in zs])
            b = float(e.xreplace(dict.fromkeys(zs, 0)))
            out: tuple[Any, ...] = ("linear", a, b)
        else:
            uses_t = self.t_index is None and t_sym in free
            syms = list(zs) + list(self.inputs) + ([t_sym] if uses_t else [])
            out = ("interval", IntervalFunction([e], syms), uses_t)
        self.cache[(mode, key) if local else key] = out
        return out


def _linear_bounds(supports: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(k, 2)`` bounds of ``a_i . z + b_i`` from the supports of ``a_i`` then ``-a_i``."""
    k = b.size
    hi = supports[:k] + b
    lo = -supports[k:] + b
    slack = SLACK * (1.0 + np.abs(lo) + np.abs(hi))
    return np.column_stack([np.nextafter(lo - slack, -np.inf), np.nextafter(hi + slack, np.inf)])


@dataclass(frozen=True, eq=False)
class ReachSet:
    """One flowpipe piece: every state reachable in ``mode`` at every time in ``t``.

    Attributes
    ----------
    mode : str
        The mode.
    t : tuple of float
        A time interval the set covers: every trajectory from the initial set
        that is in ``mode`` (after ``jumps`` jumps) at a time in ``t`` is in
        :attr:`set` at that time, in dense time.
    jumps : int
        Jumps along the branch that led here.
    set : Zonotope
        Over the model's states, in ``compiled.state_names`` order.

    Examples
    --------
    >>> import hybridlab
    >>> result = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
    ...                          t_end=1.0, step=0.1)
    >>> first = result.sets[0]  # heating over the first step (its times widened by an ulp)
    >>> first.mode, first.jumps, round(first.t[1], 9), first.bounds().round(4).tolist()
    ('heat', 0, 0.1, [[19.0, 21.1993]])
    >>> first.contains([[20.0], [21.5]]).tolist()
    [True, False]
    """

    mode: str
    t: tuple[float, float]
    jumps: int
    set: Zonotope
    _full: Zonotope = field(repr=False)
    _context: _Context = field(repr=False)
    _box: np.ndarray | None = field(default=None, repr=False)
    _bounded: dict[tuple[Any, ...], np.ndarray] = field(default_factory=dict, repr=False)
    """:meth:`bound_all`'s answers by expressions: a verdict bounds each set's spec rows
    while it flows (to stop at the first unproved set) and again over the result."""

    def __repr__(self) -> str:
        b = ", ".join(f"[{lo:.6g}, {hi:.6g}]" for lo, hi in self.bounds())
        return (f"ReachSet(mode={self.mode!r}, t=({self.t[0]:.6g}, {self.t[1]:.6g}), "
                f"jumps={self.jumps}, bounds=[{b}])")

    @property
    def nbytes(self) -> int:
        """Bytes of the kept sets' centres and generators (:attr:`set` and the set over
        the extended state, counted once where they are one): what ``max_memory``
        counts.

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
        ...                          t_end=1.0, step=0.1)
        >>> result.sets[0].nbytes > 0, result.nbytes == sum(s.nbytes for s in result.sets)
        (True, True)
        """
        kept = {id(self.set): self.set, id(self._full): self._full}.values()
        return sum(Z.center.nbytes + Z.generators.nbytes for Z in kept)

    def bounds(self) -> np.ndarray:
        """Bounds of the states, shape ``(n, 2)``: the interval hull of :attr:`set`
        within the mode's linear invariant rows (exact, by a one-multiplier LP dual)."""
        return self.set.bounds() if self._box is None else self._box.copy()

    def bound(self, expr: str | sp.Expr) -> tuple[float, float]:
        """A sound enclosure of ``expr`` over this set.

        ``expr`` is a sympy expression in the model's state (and parameter)
        symbols, or a text in the model's expression language. Exact (support
        function) when it is linear in the states and uncertain parameters;
        interval arithmetic over the set's interval hull otherwise. Uncertain
        parameters range over their intervals, ``t`` over :attr:`t`. A name defined
        per mode (a mode's ``definitions``) reads this set's mode's definition.

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
        ...                          t_end=1.0, step=0.1)
        >>> lo, hi = result.sets[0].bound("2*T + 1")
        >>> bool(lo <= 39.0 and hi >= 43.0)
        True
        """
        ctx = self._context
        compiled = ctx.compile(expr, self.mode)
        if compiled[0] == "linear":
            _, a, b = compiled
            lo, hi = _linear_bounds(self._full.supports(np.vstack([a, -a])), np.array([b]))[0]
            return float(lo), float(hi)
        _, f, uses_t = compiled
        env = [Interval(float(lo), float(hi)) for lo, hi in self._full.bounds()]
        env += [Interval(*ctx.inputs[s]) for s in ctx.inputs]
        if uses_t:
            env.append(Interval(*self.t))
        r = f.intervals(env)[0]
        return r.lo, r.hi

    def bound_all(self, exprs: Sequence[str | sp.Expr]) -> np.ndarray:
        """:meth:`bound` of each expression, shape ``(k, 2)``; the linear ones in one product.

        Examples
        --------
        >>> import hybridlab
        >>> result = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
        ...                          t_end=1.0, step=0.1)
        >>> rs = result.sets[0]
        >>> bool(np.array_equal(rs.bound_all(["T", "2*T + 1"])[1], rs.bound("2*T + 1")))
        True
        """
        key = tuple(exprs)
        known = self._bounded.get(key)
        if known is not None:
            return known.copy()
        out = np.empty((len(exprs), 2))
        rows, directions, b, others = self._context.stacked(key, self.mode)
        for k in others:
            out[k] = self.bound(exprs[k])
        if rows:
            out[rows] = _linear_bounds(self._full.supports(directions), b)
        self._bounded[key] = out
        return out.copy()

    def contains(self, x: Sequence[float] | np.ndarray, tol: float = 1e-9) -> np.ndarray:
        """Whether state(s) ``x`` (rows, model state order) lie in :attr:`set`."""
        return self.set.contains_points(x, tol)


@dataclass(frozen=True, eq=False)
class ReachResult:
    """The outcome of :func:`hybridlab.reach`.

    Attributes
    ----------
    sets : tuple of ReachSet
        The flowpipes, in the order they were computed.
    bounds : dict
        Per state, ``(lo, hi)`` over everything reached.
    reachable_modes : frozenset of str
        Modes some set lies in.
    complete : bool
        Every branch was followed to ``t_end`` (or to a fixpoint, or until its set
        left the mode's invariant); nothing was cut by ``max_jumps``, the set budget
        or a failed step.
    incomplete_reasons : tuple of str
        Why not, one line each.
    fixpoint : bool
        Every branch ended in a fixpoint (or died): the union of the sets then
        contains every state reachable at any time, not only up to ``t_end``.
    time_s : float
        Wall-clock time of the analysis.
    state_names : tuple of str
    t_span : tuple of float
        ``(t_start, t_end)``.
    options : ReachOptions
        The settings used (with the step filled in).
    stopped_unproved : bool
        The analysis ended at a set that does not prove one of the specs it was
        asked to stop on (``stop_unproved``).
    unproved_between_steps : bool
        ``stopped_unproved``, and the sets at both ends of the step of the set it
        stopped at prove every spec: the failure lies between two step instants, where
        a smaller step tightens the set.
    too_wide : bool
        Incomplete only because nonlinear modes' sets outgrew their linearisation (a
        smaller step or a split initial set may get further); not when a budget
        (``max_sets``, ``max_jumps``, the time) also ended a branch.
    split_direction : array or None
        Where the analysis ended (a set outgrew its remainder, or did not prove a spec
        it was asked to stop on) in a Taylor model started from the initial set itself
        (no jump before): the generator of the initial set along which that model bent
        most, where a split pays most (``split="auto"`` cuts there); else ``None``.
    pieces : int
        The analyses whose sets this result holds (1 unless the initial set was split).
    nonlinear : bool
        Some set was computed in a mode whose flow is not affine in the extended state
        (an uncertain parameter times a state counts): there the sets' looseness grows
        with their width, so pieces of the initial set are tighter.

    Examples
    --------
    The thermostat from ``T`` in ``[19, 21]``: heating until ``T = 22``, then cooling.

    >>> import hybridlab
    >>> result = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
    ...                          t_end=1.0, step=0.1)
    >>> result.complete, sorted(result.reachable_modes), len(result.sets)
    (True, ['cool', 'heat'], 16)
    >>> [round(b, 4) for b in result.bounds["T"]]
    [19.0, 22.0]
    >>> [s.mode for s in result.sets_at(0.55)]
    ['heat', 'cool']
    >>> result.covers([0.5, 0.5], [[20.0], [23.0]]).tolist()  # simulated samples (t, T)
    [True, False]
    """

    sets: tuple[ReachSet, ...]
    bounds: dict[str, tuple[float, float]]
    reachable_modes: frozenset[str]
    complete: bool
    incomplete_reasons: tuple[str, ...]
    fixpoint: bool
    time_s: float
    state_names: tuple[str, ...] = ()
    t_span: tuple[float, float] = (0.0, 0.0)
    options: ReachOptions = field(default_factory=ReachOptions, repr=False)
    stopped_unproved: bool = False
    unproved_between_steps: bool = False
    too_wide: bool = False
    split_direction: np.ndarray | None = field(default=None, repr=False)
    pieces: int = 1
    nonlinear: bool = False

    def __repr__(self) -> str:
        bounds = ", ".join(f"{k}: [{lo:.6g}, {hi:.6g}]" for k, (lo, hi) in self.bounds.items())
        return (f"ReachResult({len(self.sets)} sets, complete={self.complete}, "
                f"fixpoint={self.fixpoint}, modes={sorted(self.reachable_modes)}, "
                f"bounds={{{bounds}}}, t_span={self.t_span}, time_s={self.time_s:.3g}"
                + (f", incomplete_reasons={list(self.incomplete_reasons)}"
                   if self.incomplete_reasons else "") + ")")

    @property
    def nbytes(self) -> int:
        """Bytes of every set's centre and generators (:attr:`ReachSet.nbytes`)."""
        return sum(s.nbytes for s in self.sets)

    def bound(self, expr: str | sp.Expr, mode: str | None = None) -> tuple[float, float]:
        """Enclosure of ``expr`` over every set (of ``mode``, if given)."""
        pieces = [s.bound(expr) for s in self.sets if mode is None or s.mode == mode]
        if not pieces:
            raise ValueError(f"no reach set{'' if mode is None else f' in mode {mode!r}'}")
        return min(p[0] for p in pieces), max(p[1] for p in pieces)

    def sets_at(self, t: float, mode: str | None = None) -> tuple[ReachSet, ...]:
        """The sets whose time interval contains ``t``."""
        return tuple(s for s in self.sets
                     if s.t[0] <= t <= s.t[1] and (mode is None or s.mode == mode))

    def covers(self, t: Sequence[float] | np.ndarray, x: np.ndarray,
               modes: Sequence[str] | str | None = None, tol: float = 1e-9) -> np.ndarray:
        """Whether each sample ``(t_k, x_k, mode_k)`` lies in some set covering ``t_k``.

        Parameters
        ----------
        t : array of shape (k,)
        x : array of shape (k, n)
            States in model order.
        modes : str or sequence of str, optional
            The mode of each sample (or one for all); ``None`` accepts any mode.
        tol : float
            Relative membership tolerance (see :meth:`Zonotope.contains_points`).

        Returns
        -------
        numpy.ndarray of bool, shape (k,)
        """
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        X = np.atleast_2d(np.asarray(x, dtype=float))
        if X.shape != (ts.size, len(self.state_names)):
            raise ValueError(f"x must have shape ({ts.size}, {len(self.state_names)}) "
                             f"(got {X.shape})")
        if isinstance(modes, str):
            modes = [modes] * ts.size
        mode_arr = None if modes is None else np.asarray(list(modes), dtype=object)
        covered = np.zeros(ts.size, dtype=bool)
        for s in self.sets:
            sel = (~covered) & (ts >= s.t[0]) & (ts <= s.t[1])
            if mode_arr is not None:
                sel &= mode_arr == s.mode
            idx = np.flatnonzero(sel)
            if idx.size == 0:
                continue
            box = s.set.bounds()
            pre = np.all((X[idx] >= box[:, 0] - 1e-9) & (X[idx] <= box[:, 1] + 1e-9), axis=1)
            idx = idx[pre]
            if idx.size:
                covered[idx] = s.set.contains_points(X[idx], tol)
        return covered

    def plot(self, x: str, y: str, ax: Any = None, traces: Sequence[Any] | None = None,
             **style: Any) -> Any:
        """Flowpipes projected on ``(x, y)`` (state names or ``"t"``), traces overlaid.

        See :func:`hybridlab.reachability.plot.plot_reach`.
        """
        from hybridlab.reachability.plot import plot_reach

        return plot_reach(self, x, y, ax=ax, traces=traces, **style)

    def as_dict(self, include_sets: bool = False) -> dict[str, Any]:
        """JSON-ready summary; ``include_sets`` adds every set's mode, time and bounds."""
        out: dict[str, Any] = {
            "complete": self.complete,
            "incomplete_reasons": list(self.incomplete_reasons),
            "fixpoint": self.fixpoint,
            "time_s": self.time_s,
            "t_span": list(self.t_span),
            "bounds": {k: [float(v[0]), float(v[1])] for k, v in self.bounds.items()},
            "reachable_modes": sorted(self.reachable_modes),
            "n_sets": len(self.sets),
            "max_jumps": max((s.jumps for s in self.sets), default=0),
        }
        if include_sets:
            out["sets"] = [{"mode": s.mode, "t": [float(s.t[0]), float(s.t[1])],
                            "jumps": s.jumps, "bounds": s.bounds().tolist()} for s in self.sets]
        return out

    def to_json(self, path: str | Path | None = None, include_sets: bool = False) -> str:
        """:meth:`as_dict` as JSON text, also written to ``path`` if given."""
        text = json.dumps(self.as_dict(include_sets), indent=2)
        if path is not None:
            replace_text(path, text + "\n")
        return text


def merge_results(results: Sequence[ReachResult]) -> ReachResult:
    """One result from the analyses of the pieces of a split initial set.

    Examples
    --------
    >>> import hybridlab
    >>> whole = hybridlab.reach("models/thermostat.toml", initial={"T": (19.0, 21.0)},
    ...                         t_end=2.0, step=0.1)
    >>> merged = merge_results([whole, whole])
    >>> len(merged.sets) == 2 * len(whole.sets), merged.bounds == whole.bounds
    (True, True)
    """
    if not results:
        raise ValueError("merge_results needs at least one result")
    first = results[0]
    sets = tuple(s for r in results for s in r.sets)
    bounds: dict[str, tuple[float, float]] = {}
    for r in results:
        for k, (lo, hi) in r.bounds.items():
            old = bounds.get(k)
            bounds[k] = (lo, hi) if old is None else (min(old[0], lo), max(old[1], hi))
    reasons = tuple(dict.fromkeys(x for r in results for x in r.incomplete_reasons))
    return ReachResult(
        sets=sets, bounds=bounds,
        reachable_modes=frozenset().union(*(r.reachable_modes for r in results)),
        complete=all(r.complete for r in results), incomplete_reasons=reasons,
        fixpoint=all(r.fixpoint for r in results), time_s=sum(r.time_s for r in results),
        state_names=first.state_names, t_span=first.t_span, options=first.options,
        stopped_unproved=any(r.stopped_unproved for r in results),
        unproved_between_steps=any(r.stopped_unproved for r in results) and all(
            r.unproved_between_steps for r in results if r.stopped_unproved),
        too_wide=any(r.too_wide for r in results)
        and all(r.too_wide or r.complete for r in results),
        pieces=sum(r.pieces for r in results),
        nonlinear=any(r.nonlinear for r in results))
