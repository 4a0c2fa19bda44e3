"""Targeted splitting of the initial set: bisect only the pieces that fail, where it pays.

``split="auto"`` (:class:`~hybridlab.reachability.options.ReachOptions`) analyses the
initial set whole first. A piece whose analysis ends because a set outgrew its remainder
(``too_wide``) or, when the caller asked to stop there, because a set did not prove a
spec (``stopped_unproved``) is cut in two along one generator and both halves are
analysed again; pieces that end otherwise (complete, or out of a budget) are kept. Each
round analyses all waiting pieces together, so an executor runs them in parallel.

**The direction.** A Taylor model started from the piece records where it bent most when
the analysis ended (:func:`~hybridlab.reachability.taylor.bend`: the share of its
nonlinear coefficients that halving each initial-set variable removes), reported as
``ReachResult.split_direction``; the piece is cut along its generator parallel to that.
On the coupled Van der Pol oscillators with the coupling ``b`` in ``[1, 3]`` this picks
``b`` first (its effect is purely nonlinear: at the centre of the box the oscillators
are in phase and the coupling vanishes), then ``x1`` and ``x2``. Where no direction is
known (linearisation, or a failure after a jump) the generator halved least so far is
cut, the first of them on a tie.

**The budget.** At most ``max_pieces`` analyses in all, the failed ones included; a
piece that would need more is kept as it is, and the result says so. The pieces'
union is the initial set, so the merged result encloses every trajectory from it
exactly as the pieces' results do.

Examples
--------
The cubic decay ``x' = -x^3`` from a wide interval with a long step: the whole set's
linearisation does not settle; the upper half, where the flow is more curved, is cut
further, so five pieces get through (equal pieces need six).

>>> import hybridlab
>>> cubic = hybridlab.model_from_dict({
...     "name": "cubic", "states": {"x": 1.0},
...     "modes": {"run": {"flow": {"x": "-x**3"}}}, "initial": {"mode": "run"}})
>>> whole = hybridlab.reach(cubic, initial={"x": (0.5, 2.0)}, t_end=1.0, step=0.1)
>>> whole.complete, whole.too_wide
(False, True)
>>> auto = hybridlab.reach(cubic, initial={"x": (0.5, 2.0)}, t_end=1.0, step=0.1,
...                        split="auto")
>>> auto.complete, auto.pieces
(True, 5)
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from hybridlab.reachability.result import ReachResult, merge_results
from hybridlab.reachability.sets import Zonotope

__all__ = ["bisect", "cut_axis"]

_PARALLEL = 0.999
"""Least ``|cos|`` between a reported direction and the generator it names."""


def cut_axis(generators: np.ndarray, direction: np.ndarray | None,
             cuts: Sequence[int] | np.ndarray) -> int:
    """The column of ``generators`` to halve: the one parallel to ``direction`` if there
    is one, else the one halved least so far (``cuts``), the first on a tie.

    Examples
    --------
    >>> G = np.array([[0.5, 0.0], [0.0, 2.0]])
    >>> cut_axis(G, np.array([0.0, -1.0]), [0, 3]), cut_axis(G, None, [1, 0])
    (1, 1)
    >>> cut_axis(G, np.array([1.0, 1.0]), [0, 0])  # not parallel to either: the least cut
    0
    """
    if direction is not None and generators.shape[1]:
        norms = np.linalg.norm(generators, axis=0) * float(np.linalg.norm(direction))
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.abs(direction @ generators) / norms
        cos = np.where(norms > 0, cos, 0.0)
        best = int(np.argmax(cos))
        if cos[best] >= _PARALLEL:
            return best
    return int(np.argmin(np.asarray(cuts)))


def bisect(analyse: Callable[[list[Zonotope], int], list[ReachResult]], initial: Zonotope,
           max_pieces: int, deadline: float | None = None) -> ReachResult:
    """Analyse ``initial``, then the halves of every piece that failed, round by round.

    Parameters
    ----------
    analyse : callable
        Maps a list of pieces and the bytes of the sets kept so far to the pieces'
        results, in order (one round; it may run them in parallel, sharing what is left
        of ``max_memory``).
    initial : Zonotope
        The initial set (states and uncertain parameters).
    max_pieces : int
        The most analyses in all.
    deadline : float, optional
        The ``time.time()`` after which no piece is cut again.

    Returns
    -------
    ReachResult
        The kept pieces' results merged; ``pieces`` is their number and ``time_s`` the
        wall-clock time of every round.

    Examples
    --------
    >>> import hybridlab
    >>> from hybridlab.reachability.hybrid import run_analysis
    >>> from hybridlab.reachability.options import ReachOptions
    >>> from hybridlab.reachability.system import build_system
    >>> cubic = hybridlab.compile_model(hybridlab.model_from_dict({
    ...     "name": "cubic", "states": {"x": 1.0},
    ...     "modes": {"run": {"flow": {"x": "-x**3"}}}, "initial": {"mode": "run"}}))
    >>> p = cubic.parameter_vector()
    >>> system = build_system(cubic, p, {}, {})
    >>> def analyse(pieces, held):
    ...     return [run_analysis(system, ReachOptions(step=0.1), "run", P, 0.0, 1.0, p)
    ...             for P in pieces]
    >>> result = bisect(analyse, Zonotope([1.25], [[0.75]]), max_pieces=16)
    >>> result.complete, result.pieces
    (True, 5)
    >>> print(bisect(analyse, Zonotope([1.25], [[0.75]]), max_pieces=2).incomplete_reasons[-1])
    split='auto': 1 piece(s) still failed when the budget of max_pieces=2 analyses ran out
    """
    started = time.perf_counter()
    whole = initial.compact()
    n_gen = whole.generators.shape[1]
    pending: list[tuple[Zonotope, np.ndarray]] = [(whole, np.zeros(n_gen, dtype=int))]
    kept: list[ReachResult] = []
    analysed = short = 0
    while pending:
        results = analyse([Z for Z, _ in pending], sum(r.nbytes for r in kept))
        analysed += len(pending)
        waiting: list[tuple[Zonotope, np.ndarray]] = []
        for (Z, cuts), result in zip(pending, results, strict=True):
            failed = not result.complete and (result.too_wide or result.stopped_unproved)
            if not failed or n_gen == 0:
                kept.append(result)
                continue
            if (analysed + len(waiting) + 2 > max_pieces
                    or deadline is not None and time.time() >= deadline):
                kept.append(result)
                short += 1
                continue
            j = cut_axis(Z.generators, result.split_direction, cuts)
            g = 0.5 * Z.generators[:, j]
            G = Z.generators.copy()
            G[:, j] = g
            more = cuts.copy()
            more[j] += 1
            waiting += [(Zonotope(Z.center - g, G), more), (Zonotope(Z.center + g, G), more)]
        pending = waiting
    merged = merge_results(kept)
    if short:
        why = (f"split='auto': {short} piece(s) still failed when the budget of "
               f"max_pieces={max_pieces} analyses ran out")
        if deadline is not None and time.time() >= deadline:
            why = f"split='auto': {short} piece(s) still failed when the time ran out"
        merged = replace(merged, incomplete_reasons=(*merged.incomplete_reasons, why))
    return replace(merged, time_s=time.perf_counter() - started)
