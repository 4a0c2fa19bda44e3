"""Resolving a model argument and its scenario, shared by every entry point above.

``simulate``, ``reach``, falsification and the identification fits all accept a
:class:`~hybridlab.model.schema.Model`, a :class:`CompiledModel` or a path, and a
scenario name defaulting to ``"default"`` when the model has one.
"""

from __future__ import annotations

from pathlib import Path

from hybridlab.model.loader import load_model
from hybridlab.model.schema import Model, Scenario
from hybridlab.symbolic.compile import CompiledModel, compile_model

__all__ = ["as_compiled", "scenario_of"]


def as_compiled(model: Model | CompiledModel | str | Path) -> CompiledModel:
    """The compiled model of a Model, a CompiledModel (returned as is) or a model file path.

    Examples
    --------
    >>> compiled = as_compiled("models/bouncing_ball.toml")
    >>> as_compiled(compiled) is compiled, compiled.model.name
    (True, 'bouncing_ball')
    """
    if isinstance(model, CompiledModel):
        return model
    if isinstance(model, str | Path):
        model = load_model(model)
    if not isinstance(model, Model):
        raise TypeError(f"model must be a Model, CompiledModel or path (got "
                        f"{type(model).__name__})")
    return compile_model(model)


def scenario_of(spec: Model, scenario: str | None, *, prefix: str = "",
                error: type[Exception] = ValueError) -> Scenario | None:
    """The named scenario, the model's ``"default"`` one when unnamed, else None.

    Examples
    --------
    >>> ball = load_model("models/bouncing_ball.toml")
    >>> scenario_of(ball, None) is ball.scenarios.get("default")
    True
    >>> scenario_of(ball, "nope")
    Traceback (most recent call last):
    ...
    ValueError: unknown scenario 'nope'; the model has: ...
    """
    if scenario is None and "default" in spec.scenarios:
        scenario = "default"
    if scenario is None:
        return None
    if scenario not in spec.scenarios:
        known = ", ".join(spec.scenarios) or "none"
        raise error(f"{prefix}unknown scenario {scenario!r}; the model has: {known}")
    return spec.scenarios[scenario]
