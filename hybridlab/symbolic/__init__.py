"""Symbolic layer: discontinuity extraction and compilation to numeric functions."""

from hybridlab.symbolic.compile import (
    CompiledMode,
    CompiledModel,
    CompiledTransition,
    compile_model,
)
from hybridlab.symbolic.discontinuities import Switch, extract_switches
from hybridlab.symbolic.functions import MatrixFunction, VectorFunction

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
