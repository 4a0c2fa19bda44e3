"""Safety specifications: inequalities that must hold, or regions to avoid.

A spec is bound to a model when it is parsed: every name is resolved with the
whitelist expression parser (never ``eval``), mode names are checked, and
mode-local definitions are substituted for each mode the spec covers. Every
spec reduces to *rows* ``g_i(x, p)``:

* a :func:`parse_spec` text such as ``"x >= -100 and v <= 2"`` holds when every
  row is ``>= 0`` (``kind="all"``); its *margin* is ``min_i g_i``;
* an :class:`Avoid` region (a box or a polytope ``A x <= b``) is avoided when at
  least one row ``a_i x - b_i`` is ``> 0`` (``kind="any"``, strict); its margin
  is ``max_i g_i``.

A negative margin (zero too for a region to avoid) is a violation. Strict and
non-strict inequalities in a text are treated alike, as guards are.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from hybridlab.errors import ExpressionError, HybridlabError, ModelError
from hybridlab.model.checks import TIME
from hybridlab.model.expressions import parse_relation
from hybridlab.model.names import match_modes
from hybridlab.model.schema import Model
from hybridlab.symbolic.compile import CompiledModel, compile_model

__all__ = ["SpecError", "Spec", "Avoid", "parse_spec", "as_specs"]

#: ``MODE, MODE:`` before a relation; a mode of a product may be named by some of its
#: components' modes (``room1.on|heater.heat1``), see :func:`hybridlab.model.names.match_modes`
_MODE_PREFIX = re.compile(r"^\s*([A-Za-z_*][\w*.|]*(?:\s*,\s*[A-Za-z_*][\w*.|]*)*)\s*:(?!=)")


class SpecError(HybridlabError, ValueError):
    """A safety spec is malformed; the message names the spec text and the token.

    Examples
    --------
    >>> str(SpecError("x >= y", "unknown symbol", "y"))
    "spec 'x >= y': unknown symbol (token 'y')"
    """

    def __init__(self, spec: str, message: str, token: str = "") -> None:
        super().__init__(message)
        self.spec = spec
        self.message = message
        self.token = token

    def __str__(self) -> str:
        text = f"spec {self.spec!r}: {self.message}"
        return f"{text} (token {self.token!r})" if self.token else text


@dataclass(frozen=True)
class Spec:
    """A safety spec bound to one model.

    Attributes
    ----------
    text : str
        How the spec was written (or a description of an :class:`Avoid` region).
    kind : {"all", "any"}
        ``"all"``: every row must be ``>= 0``; ``"any"``: some row must be ``> 0``.
    rows : mapping of str to tuple of sympy.Expr
        For every mode the spec covers, the rows over states and parameters
        (mode-local definitions substituted).
    row_texts : tuple of str
        One text per row.
    modes : tuple of str or None
        The modes the spec is restricted to (``None``: every mode).

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> spec = parse_spec("fall: h >= -1 and v <= 20", ball)
    >>> spec.modes, spec.rows["fall"]
    (('fall',), (h + 1, 20 - v))
    >>> spec.margin(np.array([[0.5, 3.0], [17.0, -10.0]]))  # rows at two points
    array([  0.5, -10. ])
    """

    text: str
    kind: str
    rows: Mapping[str, tuple[sp.Expr, ...]] = field(repr=False)
    row_texts: tuple[str, ...] = ()
    modes: tuple[str, ...] | None = None

    @property
    def strict(self) -> bool:
        """A zero margin is a violation (regions to avoid are closed)."""
        return self.kind == "any"

    def covers(self, mode: str) -> bool:
        """Whether the spec constrains states in ``mode``."""
        return mode in self.rows

    def margin(self, values: np.ndarray) -> np.ndarray:
        """Combine row values of shape ``(m, k)`` into ``k`` margins."""
        values = np.asarray(values, dtype=float)
        return values.min(axis=0) if self.kind == "all" else values.max(axis=0)

    def violated(self, margin: float | np.ndarray) -> np.ndarray | bool:
        """``margin < 0`` (``<= 0`` for a region to avoid)."""
        return margin <= 0 if self.strict else margin < 0

    def holds(self, lower: float) -> bool:
        """Whether a lower bound of the margin proves the spec (``> 0`` for a region)."""
        return lower > 0 if self.strict else lower >= 0

    def lower_on(self, reach_set: Any) -> float | None:
        """A lower bound of the margin over one ``ReachSet`` (``None``: not in a covered mode)."""
        rows = self.rows.get(reach_set.mode)
        if rows is None:
            return None
        return self.lower_from(reach_set.bound_all(rows))

    def lower_from(self, row_bounds: np.ndarray) -> float:
        """The margin's lower bound from ``(k, 2)`` bounds of this spec's rows."""
        return self.combine_lower(row_bounds[:, 0].tolist())

    def combine_lower(self, row_lower: Sequence[float]) -> float:
        """A lower bound of the margin from lower bounds of its rows.

        For ``"all"`` this is exact given exact row bounds; for ``"any"`` it is
        the best single separating row (sound, possibly conservative).
        """
        return float(min(row_lower) if self.kind == "all" else max(row_lower))


def lowers_on(specs: Sequence[Spec], reach_set: Any) -> list[float | None]:
    """:meth:`Spec.lower_on` of each spec, the rows of all of them bounded at once.

    Examples
    --------
    >>> import hybridlab
    >>> compiled = hybridlab.compile_model(hybridlab.load_model("models/thermostat.toml"))
    >>> result = hybridlab.reach(compiled, initial={"T": (19.0, 21.0)}, t_end=1.0, step=0.1)
    >>> specs = as_specs(["T <= 25", "cool: T >= 18"], compiled)
    >>> first = result.sets[0]  # heating: the second spec does not cover it
    >>> lowers_on(specs, first) == [s.lower_on(first) for s in specs]
    True
    >>> lowers_on(specs, first)[1] is None
    True
    """
    exprs: list[Any] = []
    spans: list[tuple[int, int] | None] = []
    for spec in specs:
        rows = spec.rows.get(reach_set.mode)
        if rows is None:
            spans.append(None)
            continue
        spans.append((len(exprs), len(exprs) + len(rows)))
        exprs.extend(rows)
    if not exprs:
        return [None] * len(specs)
    bounds = reach_set.bound_all(exprs)
    return [None if span is None else spec.lower_from(bounds[span[0]:span[1]])
            for spec, span in zip(specs, spans, strict=True)]


def _fail(spec: str, exc: ExpressionError | ModelError) -> SpecError:
    return SpecError(spec, exc.message, exc.token)


def _compiled(model: Model | CompiledModel) -> CompiledModel:
    if isinstance(model, CompiledModel):
        return model
    if isinstance(model, Model):
        return compile_model(model)
    raise TypeError(f"model must be a hybridlab.Model or CompiledModel "
                    f"(got {type(model).__name__})")


def _select_modes(text: str, names: str | None, compiled: CompiledModel) -> tuple[str, ...] | None:
    if names is None:
        return None
    chosen: list[str] = []
    for name in (n.strip() for n in names.split(",")):
        if name == "*":
            return None
        matched = match_modes(name, list(compiled.modes))
        if not matched:
            raise SpecError(text, f"unknown mode; the model has: {', '.join(compiled.modes)}",
                            name)
        chosen.extend(m for m in matched if m not in chosen)
    return tuple(chosen)


def _scope(text: str, exprs: Sequence[sp.Expr], modes: Iterable[str],
           compiled: CompiledModel, explicit: bool) -> dict[str, tuple[sp.Expr, ...]]:
    sym = compiled.symbolic
    rows: dict[str, tuple[sp.Expr, ...]] = {}
    for mode in modes:
        try:
            rows[mode] = tuple(sym.modes[mode].scoped(e, sym.local_names) for e in exprs)
        except ModelError as exc:
            if explicit:
                raise _fail(text, exc) from None
            raise SpecError(text, f"{exc.message}; restrict the spec to the modes that define "
                                  f"it ('MODE, MODE: ...')", exc.token) from None
    return rows


def parse_spec(text: str, model: Model | CompiledModel) -> Spec:
    """Parse a safety spec such as ``"x >= -100"`` or ``"attempt, brake: x >= -100"``.

    Parameters
    ----------
    text : str
        ``[MODE[, MODE...]:] RELATION``. The relation is a conjunction of
        inequalities (``and``, chained ``0 <= x <= 1``) over states, parameters
        and definitions of the model, in the whitelisted expression language.
        ``*`` as the mode list means every mode.
    model : Model or CompiledModel

    Returns
    -------
    Spec

    Raises
    ------
    SpecError
        One line naming the spec text and the offending token.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> parse_spec("h >= -0.5", ball).rows["fall"]
    (h + 0.5,)
    >>> try:
    ...     parse_spec("rise: h >= 0", ball)
    ... except SpecError as exc:
    ...     print(exc)
    spec 'rise: h >= 0': unknown mode; the model has: fall (token 'rise')
    """
    if not isinstance(text, str):
        raise TypeError(f"a spec must be a string or an Avoid region (got {type(text).__name__})")
    compiled = _compiled(model)
    match = _MODE_PREFIX.match(text)
    names = match.group(1) if match else None
    body = text[match.end():] if match else text
    modes = _select_modes(text, names, compiled)
    try:
        relations = parse_relation(body, compiled.symbolic.namespace())
    except ExpressionError as exc:
        raise _fail(text, exc) from None
    exprs = [rel.expr for rel in relations]
    for expr in exprs:
        if expr.has(TIME):
            raise SpecError(text, "time is not allowed in a safety spec; restrict the spec to "
                                  "modes instead", "t")
    rows = _scope(text, exprs, modes or compiled.modes, compiled, explicit=modes is not None)
    return Spec(text=text.strip(), kind="all", rows=rows,
                row_texts=tuple(rel.text for rel in relations), modes=modes)


@dataclass(frozen=True)
class Avoid:
    """A region of the state space that must never be entered.

    Give exactly one of ``box`` or ``polytope``.

    Parameters
    ----------
    box : mapping of str to (lo, hi), or a set with ``lo`` and ``hi`` over all states
        Bounds of some states (the others are unconstrained).
    polytope : (A, b) or a set with ``A`` and ``b``
        ``{x : A x <= b}`` over all states in model order.
    modes : sequence of str, optional
        Only in these modes (default: every mode).
    name : str, optional
        A label used in messages (default: a description of the region).

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> spec = Avoid(box={"h": (-10.0, -1.0)}).bind(ball)
    >>> spec.text, spec.rows["fall"]
    ('avoid -10 <= h <= -1', (-h - 10.0, h + 1.0))
    >>> spec.margin(np.array([[-12.0, -5.0], [3.0, -4.0]]))  # h = 2 (outside), h = -5 (inside)
    array([ 3., -4.])
    """

    box: Any = None
    polytope: Any = None
    modes: tuple[str, ...] | None = None
    name: str | None = None

    def bind(self, model: Model | CompiledModel) -> Spec:
        """The :class:`Spec` of this region for ``model``."""
        compiled = _compiled(model)
        states = compiled.symbolic.states
        names = compiled.state_names
        label = self.name or "avoid region"
        if (self.box is None) == (self.polytope is None):
            raise SpecError(label, "give exactly one of box= or polytope=")
        rows: list[sp.Expr] = []
        texts: list[str] = []
        if self.box is not None:
            items = _box_items(self.box, names, label)
            for state, (lo, hi) in items:
                s = states[names.index(state)]
                rows += [sp.Float(lo) - s, s - sp.Float(hi)]
                texts += [f"{state} < {lo:g}", f"{state} > {hi:g}"]
            text = "avoid " + " and ".join(f"{lo:g} <= {s} <= {hi:g}" for s, (lo, hi) in items)
        else:
            a, b = _polytope_arrays(self.polytope, len(names), label)
            for ai, bi in zip(a, b, strict=True):
                expr = sum((sp.Float(c) * s for c, s in zip(ai, states, strict=True) if c),
                           sp.Integer(0)) - sp.Float(bi)
                rows.append(expr)
                texts.append(f"{expr} > 0")
            text = f"avoid polytope ({len(b)} inequalities)"
        if self.name:
            text = self.name
        modes = None
        if self.modes is not None:
            modes = _select_modes(text, ",".join(self.modes), compiled) if self.modes else None
        return Spec(text=text, kind="any",
                    rows={m: tuple(rows) for m in (modes or compiled.modes)},
                    row_texts=tuple(texts), modes=modes)


def _box_items(box: Any, names: Sequence[str], label: str) -> list[tuple[str, tuple[float, float]]]:
    if hasattr(box, "lo") and hasattr(box, "hi"):
        lo_v, hi_v = np.asarray(box.lo, dtype=float), np.asarray(box.hi, dtype=float)
        if lo_v.shape != (len(names),) or hi_v.shape != (len(names),):
            raise SpecError(label, f"a box set must cover all {len(names)} states", "box")
        box = {n: (lo_v[i], hi_v[i]) for i, n in enumerate(names)}
    if not isinstance(box, Mapping) or not box:
        raise SpecError(label, "box must map state names to (lo, hi)", "box")
    items: list[tuple[str, tuple[float, float]]] = []
    for state, bounds in box.items():
        if state not in names:
            raise SpecError(label, "unknown state in box", str(state))
        try:
            lo, hi = (float(v) for v in bounds)
        except (TypeError, ValueError):
            raise SpecError(label, "box bounds must be (lo, hi) numbers", str(state)) from None
        if not (np.isfinite(lo) or np.isfinite(hi)) or not lo <= hi:
            raise SpecError(label, "box bounds need lo <= hi, one of them finite", str(state))
        items.append((state, (lo, hi)))
    return items


def _polytope_arrays(poly: Any, n: int, label: str) -> tuple[np.ndarray, np.ndarray]:
    if hasattr(poly, "A") and hasattr(poly, "b"):
        a, b = poly.A, poly.b
    else:
        try:
            a, b = poly
        except (TypeError, ValueError):
            raise SpecError(label, "polytope must be (A, b) or a Polytope", "polytope") from None
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.atleast_1d(np.asarray(b, dtype=float))
    if a.shape[1] != n or a.shape[0] != b.shape[0] or a.shape[0] == 0:
        raise SpecError(label, f"polytope A must have shape (m, {n}) and b shape (m,) "
                               f"(got {a.shape} and {b.shape})", "polytope")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise SpecError(label, "polytope A and b must be finite", "polytope")
    return a, b


def as_specs(safe: str | Avoid | Spec | Iterable[str | Avoid | Spec],
             model: Model | CompiledModel) -> tuple[Spec, ...]:
    """Bind one spec or a sequence of specs (texts, :class:`Avoid`, :class:`Spec`) to a model.

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.load_model("models/bouncing_ball.toml")
    >>> [s.text for s in as_specs(["h >= -1", Avoid(box={"v": (30, 40)})], ball)]
    ['h >= -1', 'avoid 30 <= v <= 40']
    """
    if isinstance(safe, str | Avoid | Spec):
        safe = [safe]
    out: list[Spec] = []
    for item in safe:
        if isinstance(item, Spec):
            out.append(item)
        elif isinstance(item, Avoid):
            out.append(item.bind(model))
        else:
            out.append(parse_spec(item, model))
    if not out:
        raise ValueError("safe: at least one spec is needed")
    return tuple(out)
