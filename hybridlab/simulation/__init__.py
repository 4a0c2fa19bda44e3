"""Simulation layer: the engine, event location, results."""

from hybridlab.simulation.api import simulate
from hybridlab.simulation.options import METHODS, SimulationOptions
from hybridlab.simulation.result import Event, FinalState, Segment, SimulationResult, Status

__all__ = [
    "METHODS",
    "Event",
    "FinalState",
    "Segment",
    "SimulationOptions",
    "SimulationResult",
    "Status",
    "simulate",
]
