"""hybridlab: model, simulate and verify hybrid automata.

Every entry point is re-exported here and loads on first use. The packages are
layered model -> symbolic -> simulation -> (reachability, ensemble, identify,
graph, io) -> verify -> cli; a layer imports only from the layers before it
(and ``errors``).
"""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.ensemble import SweepResult, simulate_many, sweep
    from hybridlab.errors import (
        CompilationError,
        ExpressionError,
        HybridlabError,
        ModelError,
        SimulationError,
        ZenoError,
    )
    from hybridlab.graph import GraphReport, check_mode_graph, mode_graph, to_dot
    from hybridlab.identify import fit_events, fit_friction, fit_mass, fit_targets
    from hybridlab.io import load_spaceex
    from hybridlab.model import (
        Discrete,
        Initial,
        Mechanics,
        Mode,
        Model,
        Parameter,
        Scenario,
        Schedule,
        Signal,
        State,
        Transition,
        dumps_model,
        load_model,
        loads_model,
        model_from_dict,
        model_json_schema,
    )
    from hybridlab.reachability import (
        Box,
        Polytope,
        ReachOptions,
        ReachResult,
        ReachSet,
        Zonotope,
        reach,
    )
    from hybridlab.simulation import (
        Event,
        HybridProblem,
        SimulationOptions,
        SimulationResult,
        Status,
        simulate,
    )
    from hybridlab.symbolic import CompiledModel, compile_model
    from hybridlab.verify import Verdict, assert_safe, check_safety

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__version__ = "0.1.0"

__all__ = [
    "Box",
    "CompilationError",
    "CompiledModel",
    "Discrete",
    "Event",
    "ExpressionError",
    "GraphReport",
    "HybridProblem",
    "HybridlabError",
    "Initial",
    "Mechanics",
    "Mode",
    "Model",
    "ModelError",
    "Parameter",
    "Polytope",
    "ReachOptions",
    "ReachResult",
    "ReachSet",
    "Scenario",
    "Schedule",
    "Signal",
    "SimulationError",
    "SimulationOptions",
    "SimulationResult",
    "State",
    "Status",
    "SweepResult",
    "Transition",
    "Verdict",
    "ZenoError",
    "Zonotope",
    "assert_safe",
    "check_mode_graph",
    "check_safety",
    "compile_model",
    "dumps_model",
    "fit_events",
    "fit_friction",
    "fit_mass",
    "fit_targets",
    "load_model",
    "load_spaceex",
    "loads_model",
    "mode_graph",
    "model_from_dict",
    "model_json_schema",
    "reach",
    "simulate",
    "simulate_many",
    "sweep",
    "to_dot",
]
