"""Solver and event settings of one simulation."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["SimulationOptions", "METHODS", "BACKENDS"]

#: scipy integrators hybridlab can drive step by step (all have dense output).
METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
_ZENO_POLICIES = ("stop", "error")
#: simulation backends: "auto" is "compiled" when numba is installed, else "reference"
BACKENDS = ("auto", "compiled", "reference")


@dataclass(frozen=True)
class SimulationOptions:
    """Settings of the integrator and of event handling.

    Parameters
    ----------
    method : str
        One of ``RK45, RK23, DOP853`` (explicit) or ``Radau, BDF, LSODA`` (stiff).
    rtol, atol : float
        Integrator tolerances.
    max_step : float
        Largest integrator step (``inf``: no limit).
    event_tol : float
        Event times are located to ``event_tol * max(1, |t|)``.
    samples_per_step : int
        Interior points per step at which every guard is examined (values and
        time derivatives), before adaptive refinement.
    max_refine : int
        How many times a sub-interval whose guard shape is not resolved may be
        bisected.
    event_atol : float
        A guard that comes within this distance of its boundary tangentially
        (grazing) counts as reaching it.
    max_events : int
        Stop with status ``MAX_EVENTS`` after this many logged events.
    max_steps : int
        Stop with status ``STEP_LIMIT`` after this many integrator steps (the
        budget that bounds a run whatever ``t_end`` and ``max_step`` are).
    time_limit : float or None
        Stop with status ``TIME_LIMIT`` once the run has taken this many
        seconds of wall-clock time (``None``: no limit). The compiled kernel
        looks at the clock every 16 steps.
    max_event_iterations : int
        Jumps allowed at one instant (an event cascade) before the run stops
        with status ``ZENO`` (a zero-dwell cycle).
    zeno : {"stop", "error"}
        What to do when events accumulate: stop with status ``ZENO`` or raise
        :class:`hybridlab.ZenoError`.
    zeno_window : int
        Consecutive shrinking dwell times of one transition before the
        accumulation point is extrapolated.
    zeno_tol : float
        Zeno is declared once the extrapolated accumulation point is closer
        than ``zeno_tol * max(1, |t|)``.
    prove_quiet_steps : bool
        Compiled backend: before sampling a step, bound every monitor over it
        by interval arithmetic and skip the sampling when none can reach zero.
        Exact (the same events, see ``docs/semantics.md``);
        ``result.stats["quiet_steps"]`` counts the skipped steps. ``False``
        samples every step, as the reference backend does.
    backend : {"auto", "compiled", "reference"}
        ``"compiled"`` runs the numba kernel (the ``fast`` extra), falling back
        to the reference engine for what it does not support (recorded in
        ``result.stats["backend"]``); ``"auto"`` (default) is ``"compiled"``
        when numba is installed and ``"reference"`` otherwise.

    Examples
    --------
    >>> SimulationOptions(method="Radau", rtol=1e-6).atol
    1e-10
    """

    method: str = "DOP853"
    rtol: float = 1e-8
    atol: float = 1e-10
    max_step: float = math.inf
    event_tol: float = 1e-13
    samples_per_step: int = 8
    max_refine: int = 8
    event_atol: float = 1e-12
    max_events: int = 1_000_000
    max_steps: int = 10_000_000
    time_limit: float | None = None
    max_event_iterations: int = 100
    zeno: str = "stop"
    zeno_window: int = 6
    zeno_tol: float = 1e-6
    prove_quiet_steps: bool = True
    backend: str = "auto"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)} (got {self.method!r})")
        for name in ("rtol", "atol", "max_step", "event_tol", "zeno_tol"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or not value > 0:
                raise ValueError(f"{name} must be a positive number (got {value!r})")
        if not self.event_atol >= 0:
            raise ValueError(f"event_atol must be >= 0 (got {self.event_atol!r})")
        if self.time_limit is not None and (not isinstance(self.time_limit, int | float)
                                            or not self.time_limit > 0):
            raise ValueError(f"time_limit must be a positive number of seconds or None "
                             f"(got {self.time_limit!r})")
        for name in ("samples_per_step", "max_events", "max_event_iterations", "zeno_window",
                     "max_steps"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer (got {value!r})")
        if self.zeno_window < 3:
            raise ValueError(f"zeno_window must be at least 3 (got {self.zeno_window})")
        if not isinstance(self.max_refine, int) or self.max_refine < 0:
            raise ValueError(f"max_refine must be a non-negative integer (got {self.max_refine!r})")
        if not isinstance(self.prove_quiet_steps, bool):
            raise ValueError(f"prove_quiet_steps must be True or False "
                             f"(got {self.prove_quiet_steps!r})")
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {', '.join(BACKENDS)} "
                             f"(got {self.backend!r})")
        if self.zeno not in _ZENO_POLICIES:
            raise ValueError(f"zeno must be one of {_ZENO_POLICIES} (got {self.zeno!r})")

    @property
    def stiff(self) -> bool:
        """Whether the method uses the Jacobian."""
        return self.method in ("Radau", "BDF", "LSODA")
