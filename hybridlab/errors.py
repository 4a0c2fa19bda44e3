"""Exception hierarchy.

Every exception hybridlab raises on purpose derives from :class:`HybridlabError`
and from the built-in that fits it, so ``except ValueError`` keeps working.
"""

from __future__ import annotations

__all__ = [
    "HybridlabError",
    "ExpressionError",
    "ModelError",
    "CompilationError",
    "SimulationError",
    "ZenoError",
]


class HybridlabError(Exception):
    """Base class of every error raised by hybridlab.

    Examples
    --------
    One ``except`` clause catches whatever hybridlab raises on purpose:

    >>> import hybridlab
    >>> try:
    ...     hybridlab.loads_model('name = "m"')
    ... except HybridlabError as exc:
    ...     print(type(exc).__name__, isinstance(exc, ValueError))
    ModelError True
    """


class ExpressionError(HybridlabError, ValueError):
    """An expression text is not in the accepted language.

    Parameters
    ----------
    message : str
        What is wrong, in one sentence.
    token : str
        The offending piece of text (a name, an operator, a literal).

    Examples
    --------
    >>> import sympy as sp
    >>> from hybridlab.model.expressions import parse_expression
    >>> try:
    ...     parse_expression("__import__('os')", {"x": sp.Symbol("x")})
    ... except ExpressionError as exc:
    ...     print(exc, "|", exc.message, "|", exc.token)
    unknown function (token '__import__') | unknown function | __import__
    >>> str(ExpressionError("empty expression"))
    'empty expression'
    """

    def __init__(self, message: str, token: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.token = token

    def __str__(self) -> str:
        return f"{self.message} (token {self.token!r})" if self.token else self.message


class ModelError(HybridlabError, ValueError):
    """A model (file or Python object) is invalid.

    The message is always one line: ``FILE: KEY.PATH: what is wrong (token 'X')``.

    Parameters
    ----------
    message : str
        What is wrong.
    key : str, optional
        Dotted key path inside the model, such as ``modes.fall.flow.v``.
    token : str, optional
        The offending token.
    source : str, optional
        The file the model came from.

    Examples
    --------
    >>> str(ModelError("unknown symbol", key="modes.fall.flow.v", token="vv", source="ball.toml"))
    "ball.toml: modes.fall.flow.v: unknown symbol (token 'vv')"
    """

    def __init__(
        self, message: str, *, key: str = "", token: str = "", source: str = ""
    ) -> None:
        super().__init__(message)
        self.message = message
        self.key = key
        self.token = token
        self.source = source

    def with_source(self, source: str) -> ModelError:
        """Return a copy of this error that names ``source`` as its file."""
        return ModelError(self.message, key=self.key, token=self.token, source=source)

    def __str__(self) -> str:
        parts = [_one_line(p) for p in (self.source, self.key) if p]
        text = _one_line(self.message)
        if self.token:
            text += f" (token {str(self.token)!r})"  # repr escapes control characters
        return ": ".join([*parts, text])


def _one_line(text: str) -> str:
    """``text`` with line breaks and other non-printable characters escaped as in ``repr``.

    Examples
    --------
    >>> print(_one_line("fa\\nll\\x00"))
    fa\\nll\\x00
    """
    text = str(text)
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in text)


class CompilationError(HybridlabError, ValueError):
    """A valid model cannot be compiled (for example a singular mass matrix).

    Examples
    --------
    A kinetic energy without the second velocity ``w2`` has a singular mass matrix:

    >>> import sympy as sp
    >>> from hybridlab.symbolic.lagrange import lagrange_equations
    >>> x, y, w1, w2 = sp.symbols("x y w1 w2")
    >>> try:
    ...     lagrange_equations(w1**2 / 2, 0, [x, y], [w1, w2])
    ... except CompilationError as exc:
    ...     print(exc)
    mechanics: the mass matrix d2T/du2 is singular; check that the kinetic energy involves
    every velocity
    """


class SimulationError(HybridlabError, RuntimeError):
    """A simulation cannot proceed and the caller asked for an exception.

    Examples
    --------
    It is also a ``RuntimeError``, so generic handlers keep working:

    >>> try:
    ...     raise SimulationError("transition 'bounce' has no guard to evaluate")
    ... except RuntimeError as exc:
    ...     print(f"{type(exc).__name__}: {exc}")
    SimulationError: transition 'bounce' has no guard to evaluate
    """


class ZenoError(SimulationError):
    """Raised under ``zeno="error"`` when events accumulate in finite time.

    The message reads ``Zeno behaviour: ...`` and names the transition and the
    accumulation time, as ``simulate(ball, t_end=20.0, zeno="error")`` does for the
    bouncing ball.

    Examples
    --------
    >>> try:
    ...     raise ZenoError("Zeno behaviour: transition 'bounce' fired 63 times with dwell "
    ...                     "times shrinking by a factor 0.8; firings accumulate at t = 12.85")
    ... except SimulationError as exc:  # a ZenoError is a SimulationError
    ...     print(f"{type(exc).__name__}: {exc}")
    ZenoError: Zeno behaviour: transition 'bounce' fired 63 times with dwell times shrinking
    by a factor 0.8; firings accumulate at t = 12.85
    """
