"""The numba signature shared by generated models and the kernel."""

from __future__ import annotations

from numba import types
from numba.extending import intrinsic

__all__ = ["MODEL_SIGNATURE", "MODEL_TYPE", "ptr", "ptr_at"]

_PTR = types.CPointer(types.float64)

#: ``model(op, group, t, x, p, sigma, f, out)``: see :mod:`.codegen`.
MODEL_SIGNATURE = types.void(types.int64, types.int64, types.float64, _PTR, _PTR, _PTR, _PTR,
                             _PTR)
#: The first-class function type the kernel receives.
MODEL_TYPE = types.FunctionType(MODEL_SIGNATURE)


@intrinsic
def ptr(typingctx, arr):  # noqa: ARG001 - numba intrinsic protocol
    """The data pointer of a contiguous array (to call a generated model)."""
    sig = types.CPointer(arr.dtype)(arr)

    def codegen(context, builder, signature, args):
        return context.make_array(arr)(context, builder, args[0]).data

    return sig, codegen


@intrinsic
def ptr_at(typingctx, arr, offset):  # noqa: ARG001 - numba intrinsic protocol
    """The address of ``arr[offset]`` of a contiguous array."""
    sig = types.CPointer(arr.dtype)(arr, offset)

    def codegen(context, builder, signature, args):
        data = context.make_array(arr)(context, builder, args[0]).data
        return builder.gep(data, [args[1]])

    return sig, codegen
