"""Model layer: schema, safe expressions, meaning checks, file I/O."""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.model.checks import SymbolicModel, build_symbolic
    from hybridlab.model.expressions import parse_expression, parse_relation
    from hybridlab.model.loader import (
        dumps_model,
        load_model,
        loads_model,
        model_from_dict,
        model_json_schema,
    )
    from hybridlab.model.schema import (
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
    )

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "Discrete",
    "Initial",
    "Mechanics",
    "Mode",
    "Model",
    "Parameter",
    "Scenario",
    "Schedule",
    "Signal",
    "State",
    "SymbolicModel",
    "Transition",
    "build_symbolic",
    "dumps_model",
    "load_model",
    "loads_model",
    "model_from_dict",
    "model_json_schema",
    "parse_expression",
    "parse_relation",
]
