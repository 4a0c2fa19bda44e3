"""Evaluate any model expression along a simulation result."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hybridlab.errors import ExpressionError, ModelError
from hybridlab.model.checks import TIME
from hybridlab.model.expressions import parse_expression
from hybridlab.symbolic.compile import CompiledModel
from hybridlab.symbolic.functions import VectorFunction

__all__ = ["Observer"]


class Observer:
    """Compiles expressions over a model's names, once per mode.

    Definitions local to a mode are resolved in each segment's mode, so an
    expression such as ``"x_ref - x"`` follows a reference trajectory that is
    defined differently in every mode.

    Parameters
    ----------
    compiled : CompiledModel
    expressions : sequence of str
        Expression texts (parsed with the safe parser).

    Examples
    --------
    >>> import hybridlab
    >>> ball = hybridlab.compile_model(hybridlab.load_model("models/bouncing_ball.toml"))
    >>> result = hybridlab.simulate(ball, t_end=1.0)
    >>> energy = Observer(ball, ["energy"])
    >>> values = energy.evaluate(result, [0.0, 0.5])
    >>> [round(float(v), 6) for v in values[0]]
    [98.1, 98.1]
    """

    def __init__(self, compiled: CompiledModel, expressions: Sequence[str]) -> None:
        self.compiled = compiled
        sym = compiled.symbolic
        names = sym.namespace()
        self.texts = tuple(expressions)
        parsed = []
        for text in self.texts:
            try:
                parsed.append(parse_expression(text, names))
            except ExpressionError as exc:
                raise ModelError(exc.message, key="observe", token=exc.token) from None
        self._per_mode: dict[str, VectorFunction] = {}
        for name, mode in sym.modes.items():
            try:
                exprs = [mode.scoped(e, sym.local_names) for e in parsed]
            except ModelError:
                continue  # not defined in this mode: evaluating there is an error
            self._per_mode[name] = VectorFunction(exprs, TIME, sym.states, sym.parameters, ())

    def evaluate(self, result, t: float | Sequence[float] | np.ndarray | None = None,
                 params: dict[str, float] | None = None) -> np.ndarray:
        """Values at times ``t`` (post-jump at jump instants), or at every stored point.

        Returns shape ``(len(expressions), k)``.
        """
        p = self.compiled.parameter_vector({**(result.parameters or {}), **(params or {})})
        if t is None:
            pieces = [(seg.mode, seg.t, seg.y) for seg in result.segments]
        else:
            ts = np.atleast_1d(np.asarray(t, dtype=float))
            which = result.segment_index(ts)
            states = result(ts).reshape(len(result.state_names), ts.size)
            bounds = np.flatnonzero(np.diff(which)) + 1
            pieces = [(result.segments[which[c[0]]].mode, ts[c], states[:, c])
                      for c in np.split(np.arange(ts.size), bounds) if c.size]
        out = []
        for mode, ts, ys in pieces:
            if mode not in self._per_mode:
                raise ValueError(f"{', '.join(self.texts)}: not defined in mode {mode!r}")
            out.append(self._per_mode[mode].batch(ts, ys, p, np.empty(0)))
        return np.concatenate(out, axis=1)
