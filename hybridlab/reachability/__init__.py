"""Set-based reachability, sound in dense time.

``hybridlab.reach(model, initial=..., t_end=...)`` returns a
:class:`ReachResult`: zonotope flowpipes per mode that contain every state
reachable from the initial set at every time (not only at time steps), bounds
per state and the reachable modes. See ``docs/verification.md``.

Modules: :mod:`hybridlab.symbolic.intervals` (interval arithmetic), :mod:`~.sets` (boxes,
zonotopes, polytopes), :mod:`~.system` (the model's equations on the extended
state), :mod:`~.linear` (one affine step), :mod:`~.nonlinear` (conservative
linearisation), :mod:`~.hybrid` (guards, resets, waiting list),
:mod:`~.result`, :mod:`~.options`, :mod:`~.plot`.
"""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.reachability.api import ReachError, reach
    from hybridlab.reachability.linear import StepError
    from hybridlab.reachability.options import ReachOptions
    from hybridlab.reachability.result import ReachResult, ReachSet
    from hybridlab.reachability.sets import Box, Polytope, SetError, Zonotope, as_zonotope
    from hybridlab.symbolic.intervals import Interval, IntervalError, IntervalFunction

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "Box",
    "Interval",
    "IntervalError",
    "IntervalFunction",
    "Polytope",
    "ReachError",
    "ReachOptions",
    "ReachResult",
    "ReachSet",
    "SetError",
    "StepError",
    "Zonotope",
    "as_zonotope",
    "reach",
]
