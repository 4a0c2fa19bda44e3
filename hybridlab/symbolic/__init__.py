"""Symbolic layer: discontinuity extraction and compilation to numeric functions."""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.symbolic.compile import (
        CompiledMode,
        CompiledModel,
        CompiledTransition,
        compile_model,
    )
    from hybridlab.symbolic.discontinuities import Switch, extract_switches
    from hybridlab.symbolic.functions import MatrixFunction, VectorFunction

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "CompiledMode",
    "CompiledModel",
    "CompiledTransition",
    "MatrixFunction",
    "Switch",
    "VectorFunction",
    "compile_model",
    "extract_switches",
]
