"""The numba signature shared by generated models and the kernel, and the kernel's compile
settings (:data:`borrowing`, :data:`counted`)."""

from __future__ import annotations

from functools import partial

import numba
from numba import types
from numba.core import cgutils
from numba.core.cpu import CPUTargetOptions
from numba.extending import intrinsic

__all__ = ["MODEL_SIGNATURE", "MODEL_TYPE", "ptr", "ptr_at", "borrowing", "counted", "model_at"]

_PTR = types.CPointer(types.float64)

#: ``model(op, group, t, x, p, sigma, f, out)``: see :mod:`.codegen`.
MODEL_SIGNATURE = types.void(types.int64, types.int64, types.float64, _PTR, _PTR, _PTR, _PTR,
                             _PTR)
#: The first-class function type the kernel receives.
MODEL_TYPE = types.FunctionType(MODEL_SIGNATURE)


@intrinsic
def model_at(typingctx, address):  # noqa: ARG001 - numba intrinsic protocol
    """The generated function whose C entry point is at ``address`` (a ``cfunc``'s
    ``address``), as a value of :data:`MODEL_TYPE`.

    Passing the ``cfunc`` object itself costs numba's unboxing of a first-class
    function (about 7 µs of Python per argument and call); an address is an
    integer. The caller keeps the ``cfunc`` alive while the kernel runs.
    """
    sig = MODEL_TYPE(types.int64)

    def codegen(context, builder, signature, args):
        fn = cgutils.create_struct_proxy(MODEL_TYPE)(
            context, builder, value=context.get_constant_null(MODEL_TYPE))
        fn.c_addr = builder.inttoptr(args[0], cgutils.voidptr_t)  # called through its C entry
        return fn._getvalue()

    return sig, codegen


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


def _refcounting(enabled: bool) -> dict:
    """numba's option for reference counting, where this numba has it (it is an underscore
    option): without it, the functions below compile as plain ``njit``, only slower."""
    return {"_nrt": enabled} if hasattr(CPUTargetOptions, "_nrt") else {}


#: ``numba.njit(cache=True)`` for a kernel function that only *borrows* arrays, compiled
#: without numba's reference counting. Each array bound in numba code (a tuple unpacked, an
#: inlined call's parameter, a row view) otherwise costs an atomic increment and decrement;
#: in the integrator's stages and the sampler's loops these were a sixth of a run. Such a
#: function must not allocate, must not return or store an array, and may call only
#: functions inlined into it, ``borrowing`` ones, or ``counted`` ones: its callers own every
#: array it sees and keep them alive across the call.
borrowing = partial(numba.njit, cache=True, **_refcounting(False))

#: ``numba.njit(cache=True)`` with reference counting said explicitly, for a function that
#: needs it and is called from a ``borrowing`` one (whose setting it would otherwise inherit).
counted = partial(numba.njit, cache=True, **_refcounting(True))
