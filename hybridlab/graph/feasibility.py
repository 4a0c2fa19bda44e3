"""Can a conjunction of inequalities ``row >= 0`` hold? An LP or an interval test decides.

Rows are sympy expressions over states and ``t`` with parameters already
replaced by numbers. Strict and non-strict inequalities are treated alike (as
the simulator treats them: a guard holds on its boundary), and a row counts
as satisfiable when it can reach ``-tol`` (``tol`` scaled by the size of the
numbers involved), so a guard that only touches an invariant still holds.

- Every row affine: one LP (HiGHS) maximises the smallest row slack ``s``
  (rows normalised by the norm of their gradient, so ``s`` is a distance);
  ``s < -tol`` is :attr:`Feasibility.IMPOSSIBLE`, otherwise :attr:`Feasibility.POSSIBLE`.
- Some row nonlinear: the affine rows alone are decided first (impossible
  there is impossible overall); then a box is taken from the bounds the affine
  rows imply and split (branch and prune) up to ``max_boxes`` times. A box on
  which some row's interval enclosure lies below ``-tol`` holds no solution;
  a box (or a point) on which every nonlinear row is certainly ``>= -tol`` and
  the affine rows are feasible (LP) proves a solution. Nothing pruned away
  and nothing proved is :attr:`Feasibility.UNDECIDED`.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import sympy as sp

from hybridlab.symbolic.intervals import EmptyInterval, Interval, compile_interval
from hybridlab.symbolic.printing import PrintError, numpy_function

__all__ = ["Feasibility", "Decision", "decide"]

_INF = math.inf


class Feasibility(StrEnum):
    """The answer to "can these inequalities hold together?".

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> decide([x - 2, 1 - x]).verdict is Feasibility.IMPOSSIBLE  # x >= 2 and x <= 1
    True
    >>> Feasibility("possible"), Feasibility.UNDECIDED.value
    (<Feasibility.POSSIBLE: 'possible'>, 'undecided')
    """

    POSSIBLE = "possible"
    """Proved satisfiable (within ``tol``): a point was found or an LP found one."""
    IMPOSSIBLE = "impossible"
    """Proved unsatisfiable: no state satisfies every row."""
    UNDECIDED = "undecided"
    """Neither could be proved (nonlinear rows the interval test could not settle)."""


@dataclass(frozen=True)
class Decision:
    """A verdict, how it was reached, and (for an LP) the slack margin.

    Attributes
    ----------
    verdict : Feasibility
        The answer.
    method : str
        ``"constant"`` (no state appears), ``"lp"`` (every row affine),
        ``"lp+interval"`` (nonlinear rows) or ``"none"`` (no rows at all).
    margin : float or None
        For an LP: the largest achievable smallest slack (a distance in state
        space; negative when impossible).
    reason : str
        For an undecided verdict: why, naming a nonlinear row.

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> decide([x - 2, 1 - x]).verdict       # x >= 2 and x <= 1
    <Feasibility.IMPOSSIBLE: 'impossible'>
    """

    verdict: Feasibility
    method: str
    margin: float | None = None
    reason: str = ""


@dataclass(frozen=True)
class _Affine:
    coeffs: Mapping[sp.Symbol, float]
    const: float


def _number(expr: sp.Expr) -> float | None:
    try:
        value = float(expr)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _affine(expr: sp.Expr) -> _Affine | None:
    """``expr`` as ``sum(c_i v_i) + c0`` with float coefficients, or ``None`` if not affine."""
    if not expr.free_symbols:
        value = _number(expr)
        return None if value is None else _Affine({}, value)
    if expr.is_Symbol:
        return _Affine({expr: 1.0}, 0.0)
    if expr.is_Add:
        coeffs: dict[sp.Symbol, float] = {}
        const = 0.0
        for arg in expr.args:
            part = _affine(arg)
            if part is None:
                return None
            const += part.const
            for v, c in part.coeffs.items():
                coeffs[v] = coeffs.get(v, 0.0) + c
        return _Affine(coeffs, const)
    if expr.is_Mul:
        factor = 1.0
        variable: _Affine | None = None
        for arg in expr.args:
            if arg.free_symbols:
                if variable is not None:
                    return None
                variable = _affine(arg)
                if variable is None:
                    return None
            else:
                value = _number(arg)
                if value is None:
                    return None
                factor *= value
        if variable is None:  # pragma: no cover - a Mul with free symbols has a variable factor
            return None
        return _Affine({v: factor * c for v, c in variable.coeffs.items()},
                       factor * variable.const)
    return None


def _slack_lp(rows: Sequence[_Affine], variables: Sequence[sp.Symbol],
              bounds: Mapping[sp.Symbol, Interval] | None = None,
              ) -> tuple[float, np.ndarray] | None:
    """Maximise ``s`` subject to ``a_i.v + b_i >= |a_i| s`` and ``s <= 1``: ``(s, v)``."""
    from scipy.optimize import linprog  # scipy.optimize takes ~0.5 s to import: load on use

    index = {v: i for i, v in enumerate(variables)}
    n = len(variables)
    a_ub = np.zeros((len(rows), n + 1))
    b_ub = np.zeros(len(rows))
    for k, row in enumerate(rows):
        for v, c in row.coeffs.items():
            a_ub[k, index[v]] = -c
        norm = float(np.linalg.norm(a_ub[k, :n]))
        a_ub[k, n] = norm if norm > 0 else 1.0
        b_ub[k] = row.const
    box = bounds or {}
    lp_bounds = [(_finite_or_none(box[v].lo) if v in box else None,
                  _finite_or_none(box[v].hi) if v in box else None) for v in variables]
    lp_bounds.append((None, 1.0))
    cost = np.zeros(n + 1)
    cost[n] = -1.0
    result = linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=lp_bounds, method="highs")
    if result.status != 0:
        return None
    return float(-result.fun), np.asarray(result.x[:n])


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _scale(rows: Sequence[_Affine]) -> float:
    scale = 1.0
    for row in rows:
        norm = math.sqrt(sum(c * c for c in row.coeffs.values()))
        if norm > 0:
            scale = max(scale, abs(row.const) / norm)
    return scale


def _bounds(rows: Sequence[_Affine], variables: Sequence[sp.Symbol], of: sp.Symbol,
            tol: float) -> Interval:
    """The range of ``of`` over the affine rows (relaxed by ``tol``)."""
    from scipy.optimize import linprog  # loaded on use, as in _slack_lp

    index = {v: i for i, v in enumerate(variables)}
    a_ub = np.zeros((len(rows), len(variables)))
    b_ub = np.zeros(len(rows))
    for k, row in enumerate(rows):
        for v, c in row.coeffs.items():
            a_ub[k, index[v]] = -c
        b_ub[k] = row.const + tol * max(1.0, float(np.linalg.norm(a_ub[k])))
    ends = []
    for sign in (1.0, -1.0):
        cost = np.zeros(len(variables))
        cost[index[of]] = sign
        result = linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * len(variables),
                         method="highs")
        ends.append(sign * float(result.fun) if result.status == 0 else -sign * _INF)
    lo, hi = ends
    return Interval(lo - tol * max(1.0, abs(lo)), hi + tol * max(1.0, abs(hi)))


def _representative(interval: Interval) -> float:
    if math.isfinite(interval.lo) and math.isfinite(interval.hi):
        return 0.5 * (interval.lo + interval.hi)
    if math.isfinite(interval.lo):
        return interval.lo
    if math.isfinite(interval.hi):
        return interval.hi
    return 0.0


class _Search:
    """Branch and prune over boxes of the variables of the nonlinear rows."""

    def __init__(self, affine: list[_Affine], nonlinear: list[sp.Expr], tol: float) -> None:
        self.affine = affine
        self.nonlinear = nonlinear
        self.rows = [compile_interval(row) for row in nonlinear]
        self.tol = tol
        self.affine_vars = sorted({v for r in affine for v in r.coeffs}, key=str)
        self.nl_vars = sorted({v for e in nonlinear for v in e.free_symbols}, key=str)
        self.order = {v: k for k, v in enumerate(self.nl_vars)}

    def classify(self, box: Mapping[sp.Symbol, Interval]) -> str:
        """``"empty"``, ``"certain"`` (every nonlinear row holds on the box) or ``"unknown"``."""
        certain = True
        for row in self.rows:
            try:
                value = row(box)
            except EmptyInterval:
                return "empty"
            if value.hi < -self.tol:
                return "empty"
            certain = certain and value.lo >= -self.tol
        return "certain" if certain else "unknown"

    def affine_feasible(self, box: Mapping[sp.Symbol, Interval]) -> bool:
        if not self.affine:
            return True
        solved = _slack_lp(self.affine, self.affine_vars, box)
        return solved is not None and solved[0] >= -self.tol * _scale(self.affine)

    def point_proves(self, point: Mapping[sp.Symbol, float]) -> bool:
        box = {v: Interval(x, x) for v, x in point.items()}
        return self.classify(box) == "certain" and self.affine_feasible(box)

    def local_point(self, start: Mapping[sp.Symbol, float]) -> dict[sp.Symbol, float] | None:
        """A point found by least squares on the violations of every row, or ``None``."""
        from scipy.optimize import least_squares  # loaded on use, as in _slack_lp

        variables = sorted(set(self.nl_vars) | set(self.affine_vars), key=str)
        try:
            rows = numpy_function([variables], list(self.nonlinear), scalar=True)
        except PrintError:  # a construct the printer cannot express: no local search
            return None
        index = {v: k for k, v in enumerate(variables)}
        a = np.zeros((len(self.affine), len(variables)))
        b = np.array([r.const for r in self.affine])
        for k, r in enumerate(self.affine):
            for v, c in r.coeffs.items():
                a[k, index[v]] = c

        def violations(z: np.ndarray) -> np.ndarray:
            try:
                values = np.array(rows(z), dtype=float)
            except (ValueError, OverflowError, ZeroDivisionError):
                values = np.full(len(self.nonlinear), -1e6)
            values = np.where(np.isfinite(values), values, -1e6)
            return np.minimum(np.concatenate([values, a @ z + b]), 0.0)

        z0 = np.array([start.get(v, 0.0) for v in variables], dtype=float)
        try:
            fit = least_squares(violations, z0, ftol=1e-15, xtol=1e-15, gtol=1e-15,
                                max_nfev=100 * (len(variables) + 1))
        except (ValueError, np.linalg.LinAlgError):
            return None
        return dict(zip(variables, (float(v) for v in fit.x), strict=True))

    def run(self, box: dict[sp.Symbol, Interval], first_point: Mapping[sp.Symbol, float],
            max_boxes: int) -> Feasibility:
        if self.point_proves(first_point):
            return Feasibility.POSSIBLE
        queue = deque([box])
        for _ in range(max_boxes):
            if not queue:
                return Feasibility.IMPOSSIBLE
            current = queue.popleft()
            kind = self.classify(current)
            if kind == "empty":
                continue
            if kind == "certain":
                if self.affine_feasible(current):
                    return Feasibility.POSSIBLE
                continue
            halves = self.split(current)
            if not halves:  # too narrow to split further: cannot settle this box
                return Feasibility.UNDECIDED
            queue.extend(halves)
        if not queue:
            return Feasibility.IMPOSSIBLE
        # nothing proved either way: look for a point that satisfies every row
        found = self.local_point(first_point)
        if found is not None and self.point_proves({v: found[v] for v in self.nl_vars}):
            return Feasibility.POSSIBLE
        return Feasibility.UNDECIDED

    def split(self, box: Mapping[sp.Symbol, Interval]) -> list[dict]:
        v = max(self.nl_vars, key=lambda s: (box[s].width, -self.order[s]))
        lo, hi = box[v].lo, box[v].hi
        if math.isfinite(lo) and math.isfinite(hi):
            mid = 0.5 * (lo + hi)
        elif math.isfinite(lo):
            mid = lo + max(1.0, abs(lo))
        elif math.isfinite(hi):
            mid = hi - max(1.0, abs(hi))
        else:
            mid = 0.0
        if not lo < mid < hi:
            return []
        return [{**box, v: Interval(lo, mid)}, {**box, v: Interval(mid, hi)}]


def decide(rows: Iterable[sp.Expr], *, tol: float = 1e-9, max_boxes: int = 256) -> Decision:
    """Decide whether every ``row >= 0`` can hold at one point.

    Parameters
    ----------
    rows : iterable of sympy.Expr
        The inequalities, each as ``expr >= 0``, over free symbols (states and
        ``t``) only: parameters must already be numbers.
    tol : float
        Feasibility tolerance, relative to the size of the constants involved.
    max_boxes : int
        Budget of interval boxes for nonlinear rows.

    Returns
    -------
    Decision

    Examples
    --------
    >>> x, y = sp.symbols("x y", real=True)
    >>> decide([x - 1, 1 - x]).verdict          # touching: x == 1 satisfies both
    <Feasibility.POSSIBLE: 'possible'>
    >>> decide([1 - x**2 - y**2, x - 2]).verdict  # the unit disc has no point with x >= 2
    <Feasibility.IMPOSSIBLE: 'impossible'>
    >>> decide([x - x**2 - 0.3]).verdict        # true (x - x^2 <= 1/4), not provable unbounded
    <Feasibility.UNDECIDED: 'undecided'>
    """
    rows = list(rows)
    affine: list[_Affine] = []
    nonlinear: list[sp.Expr] = []
    for row in rows:
        form = _affine(row)
        if form is None:
            nonlinear.append(row)
        elif not form.coeffs:
            if form.const < -tol * max(1.0, abs(form.const)):
                return Decision(Feasibility.IMPOSSIBLE, "constant", form.const)
        else:
            affine.append(form)
    if not affine and not nonlinear:
        return Decision(Feasibility.POSSIBLE, "constant" if rows else "none")
    point: dict[sp.Symbol, float] = {}
    margin = None
    if affine:
        variables = sorted({v for r in affine for v in r.coeffs}, key=str)
        solved = _slack_lp(affine, variables)
        if solved is None:
            return Decision(Feasibility.UNDECIDED, "lp", reason="the LP solver did not converge")
        margin, x = solved
        if margin < -tol * _scale(affine):
            return Decision(Feasibility.IMPOSSIBLE, "lp", margin)
        if not nonlinear:
            return Decision(Feasibility.POSSIBLE, "lp", margin)
        point = dict(zip(variables, (float(v) for v in x), strict=True))
    search = _Search(affine, nonlinear, tol)
    affine_vars = set(search.affine_vars)
    box = {v: (_bounds(affine, search.affine_vars, v, tol) if v in affine_vars
               else Interval.entire()) for v in search.nl_vars}
    verdict = search.run(box, {v: point.get(v, _representative(box[v])) for v in search.nl_vars},
                         max_boxes)
    reason = ""
    if verdict is Feasibility.UNDECIDED:
        reason = f"nonlinear: {nonlinear[0]} >= 0"
    return Decision(verdict, "lp+interval", margin, reason)
