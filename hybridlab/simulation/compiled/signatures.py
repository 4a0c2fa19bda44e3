"""The numba signature shared by generated models and the kernel."""

from __future__ import annotations

from numba import types

__all__ = ["MODEL_SIGNATURE", "MODEL_TYPE"]

_PTR = types.CPointer(types.float64)

#: ``model(op, group, t, x, p, sigma, f, out)``: see :mod:`.codegen`.
MODEL_SIGNATURE = types.void(types.int64, types.int64, types.float64, _PTR, _PTR, _PTR, _PTR,
                             _PTR)
#: The first-class function type the kernel receives.
MODEL_TYPE = types.FunctionType(MODEL_SIGNATURE)
