"""Model layer: schema, safe expressions, meaning checks, file I/O."""

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
    Initial,
    Mechanics,
    Mode,
    Model,
    Parameter,
    Scenario,
    Schedule,
    State,
    Transition,
)

__all__ = [
    "Initial",
    "Mechanics",
    "Mode",
    "Model",
    "Parameter",
    "Scenario",
    "Schedule",
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
