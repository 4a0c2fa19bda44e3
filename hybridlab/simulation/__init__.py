"""Simulation layer: the engine, event location, results."""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.simulation.api import simulate
    from hybridlab.simulation.options import METHODS, SimulationOptions
    from hybridlab.simulation.problem import HybridProblem, ProblemError
    from hybridlab.simulation.result import Event, FinalState, Segment, SimulationResult, Status

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "METHODS",
    "Event",
    "FinalState",
    "HybridProblem",
    "ProblemError",
    "Segment",
    "SimulationOptions",
    "SimulationResult",
    "Status",
    "simulate",
]
