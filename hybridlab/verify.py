"""Safety checks for test suites: ``assert_safe`` and ``check_safety``.

::

    from hybridlab.verify import assert_safe

    def test_ball_never_goes_through_the_floor():
        assert_safe("models/bouncing_ball.toml", initial={"h": (5, 10)}, t_end=3,
                    safe=["h >= -0.01"])

A failing check raises :class:`SafetyAssertionError` (an ``AssertionError``, so
pytest reports it as a failed assertion) whose message names the violated
spec, the mode, the time and the state, or, for an undecided check, the reason
and the tightest bound. The verdict logic is in
:mod:`hybridlab.reachability.verdict`; specs in :mod:`hybridlab.reachability.spec`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from hybridlab.errors import HybridlabError
from hybridlab.model.schema import Model
from hybridlab.reachability.falsify import Counterexample, FalsifyOptions
from hybridlab.reachability.spec import Avoid, Spec, SpecError, parse_spec
from hybridlab.reachability.verdict import Verdict, VerdictStatus, check
from hybridlab.simulation.problem import HybridProblem
from hybridlab.symbolic.compile import CompiledModel

__all__ = ["Avoid", "Counterexample", "FalsifyOptions", "SafetyAssertionError", "SpecError",
           "Verdict", "VerdictStatus", "assert_safe", "check_safety", "parse_spec"]


class SafetyAssertionError(HybridlabError, AssertionError):
    """Raised by :func:`assert_safe` for an UNSAFE (or disallowed UNKNOWN) verdict.

    Attributes
    ----------
    verdict : Verdict
        The full verdict (counterexample, bounds, reach result).

    Examples
    --------
    >>> try:
    ...     assert_safe("models/thermostat.toml", initial={"T": (19.0, 21.0)}, t_end=1.0,
    ...                 safe="T <= 20.5", prove=False)
    ... except SafetyAssertionError as exc:
    ...     error = exc
    >>> isinstance(error, AssertionError), error.verdict.status.name
    (True, 'UNSAFE')
    >>> print(str(error).splitlines()[0])
    UNSAFE: spec 'T <= 20.5' violated at t=0.25317... in mode 'heat'
    """

    def __init__(self, message: str, verdict: Verdict) -> None:
        super().__init__(message)
        self.verdict = verdict


def check_safety(
    model: Model | CompiledModel | str | Path | HybridProblem,
    *,
    initial: Mapping[str, float | tuple[float, float]] | Any = None,
    t_end: float | None = None,
    safe: str | Avoid | Spec | Iterable[str | Avoid | Spec] = (),
    executor: Any = None,
    **kwargs: Any,
) -> Verdict:
    """Check safety specs from an initial set; see :func:`hybridlab.reachability.verdict.check`.

    Returns the :class:`Verdict` whatever it is (SAFE, UNSAFE or UNKNOWN).
    ``executor`` runs the pieces of a split initial set (``split=k``) on a
    pool or cluster, as in :func:`hybridlab.reach`.

    Examples
    --------
    >>> from hybridlab.verify import check_safety
    >>> v = check_safety("models/bouncing_ball.toml", initial={"h": (5.0, 10.0)}, t_end=2.0,
    ...                  safe=["v >= -13"], prove=False)
    >>> v.status.name, v.counterexample.mode, round(v.counterexample.t, 6)
    ('UNSAFE', 'fall', 1.325178)

    A :class:`~hybridlab.HybridProblem` carries the initial set and horizon:

    >>> import hybridlab
    >>> problem = hybridlab.HybridProblem.build("models/bouncing_ball.toml",
    ...                                         initial={"h": (5.0, 10.0)}, t_end=2.0)
    >>> check_safety(problem, safe="h <= 10.5").status.name
    'SAFE'
    """
    return check(model, initial=initial, t_end=t_end, safe=safe, executor=executor, **kwargs)


def _message(verdict: Verdict) -> str:
    cx = verdict.counterexample
    if cx is not None:
        state = ", ".join(f"{k}={v:.6g}" for k, v in cx.state.items())
        start = ", ".join(f"{k}={v:.6g}" for k, v in cx.initial.items())
        lines = [f"UNSAFE: spec {cx.spec!r} violated at t={cx.t:.10g} in mode {cx.mode!r}",
                 f"  state: {state}",
                 f"  lowest margin {cx.margin:.6g} at t={cx.t_worst:.6g}",
                 f"  from initial mode {cx.initial_mode!r}, state {start}"]
        if cx.inputs:
            lines.append("  inputs (constant): " + ", ".join(f"{k}={v:.6g}"
                                                             for k, v in cx.inputs.items()))
        lines.append("  replay: verdict.counterexample.replay() "
                     "(the exception's .verdict attribute)")
        return "\n".join(lines)
    return f"UNKNOWN: {verdict.reason}"


def assert_safe(
    model: Model | CompiledModel | str | Path | HybridProblem,
    *,
    initial: Mapping[str, float | tuple[float, float]] | Any = None,
    t_end: float | None = None,
    safe: str | Avoid | Spec | Iterable[str | Avoid | Spec] = (),
    params: Mapping[str, float | tuple[float, float]] | None = None,
    inputs: Mapping[str, tuple[float, float]] | None = None,
    allow_unknown: bool = False,
    executor: Any = None,
    **kwargs: Any,
) -> Verdict:
    """Assert that every trajectory from the initial set satisfies the specs.

    Parameters
    ----------
    model, initial, t_end, safe, params, inputs
        As :func:`check_safety`.
    allow_unknown : bool
        Return an UNKNOWN verdict instead of raising (falsification still
        raises on a counterexample).
    executor : optional
        Where the pieces of a split initial set (``split=k``) are analysed:
        ``"threads"``, ``"processes"``, a worker count, an Executor or a Dask
        Client, as in :func:`hybridlab.reach` (default serial).
    **kwargs
        Passed to :func:`hybridlab.reachability.verdict.check` (``mode``,
        ``scenario``, ``options``, ``falsify_options``, ``max_jumps``, ...).

    Returns
    -------
    Verdict
        When SAFE (or UNKNOWN with ``allow_unknown``).

    Raises
    ------
    SafetyAssertionError
        An ``AssertionError`` naming the violated spec, mode, time and state
        (UNSAFE) or the reason and tightest bound (UNKNOWN).

    Examples
    --------
    >>> from hybridlab.verify import assert_safe
    >>> assert_safe("models/bouncing_ball.toml", initial={"h": (5.0, 10.0)}, t_end=2.0,
    ...             safe="h <= 9.5", prove=False)
    Traceback (most recent call last):
    ...
    hybridlab.verify.SafetyAssertionError: UNSAFE: spec 'h <= 9.5' violated at t=0 in mode 'fall'
    ...
    """
    verdict = check(model, initial=initial, t_end=t_end, safe=safe, params=params,
                    inputs=inputs, executor=executor, **kwargs)
    if verdict.status is VerdictStatus.SAFE:
        return verdict
    if verdict.status is VerdictStatus.UNKNOWN and allow_unknown:
        return verdict
    raise SafetyAssertionError(_message(verdict), verdict)
