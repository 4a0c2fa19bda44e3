"""The numba signature shared by generated models and the kernel, and the kernel's compile
settings (:data:`borrowing`, :data:`counted`)."""

from __future__ import annotations

import ctypes
from functools import partial

import numba
from numba import types
from numba.core import cgutils
from numba.core.cpu import CPUTargetOptions
from numba.extending import intrinsic

__all__ = ["MODEL_SIGNATURE", "MODEL_TYPE", "ptr", "ptr_at", "borrowing", "counted", "model_at",
           "interrupt_at", "gil_ensure_at", "gil_release_at", "clock_at", "watch_addresses"]

_PTR = types.CPointer(types.float64)

#: ``model(op, group, t, x, p, sigma, f, out)``: see :mod:`.codegen`.
MODEL_SIGNATURE = types.void(types.int64, types.int64, types.float64, _PTR, _PTR, _PTR, _PTR,
                             _PTR)
#: The first-class function type the kernel receives.
MODEL_TYPE = types.FunctionType(MODEL_SIGNATURE)


def _function_at(function_type: types.FunctionType, doc: str):
    """An intrinsic turning a C entry point's address into a callable of ``function_type``.

    Addresses are arguments, never constants, so the kernel's machine code stays
    cacheable across processes.
    """
    @intrinsic
    def at(typingctx, address):  # noqa: ARG001 - numba intrinsic protocol
        sig = function_type(types.int64)

        def codegen(context, builder, signature, args):
            fn = cgutils.create_struct_proxy(function_type)(
                context, builder, value=context.get_constant_null(function_type))
            fn.c_addr = builder.inttoptr(args[0], cgutils.voidptr_t)  # called through C
            return fn._getvalue()

        return sig, codegen

    at.__doc__ = doc
    return at


model_at = _function_at(MODEL_TYPE, """The generated function whose C entry point is at
    ``address`` (a ``cfunc``'s ``address``), as a value of :data:`MODEL_TYPE`.

    Passing the ``cfunc`` object itself costs numba's unboxing of a first-class
    function (about 7 µs of Python per argument and call); an address is an
    integer. The caller keeps the ``cfunc`` alive while the kernel runs.
    """)

#: ``int PyOS_InterruptOccurred(void)``: true once after a SIGINT (Ctrl-C), which it consumes
interrupt_at = _function_at(types.FunctionType(types.intc()),
                            "CPython's ``PyOS_InterruptOccurred`` at ``address``.")
#: ``PyGILState_STATE PyGILState_Ensure(void)``: the kernel runs without the GIL and takes it
#: back for the moment it looks for Ctrl-C
gil_ensure_at = _function_at(types.FunctionType(types.intc()),
                             "CPython's ``PyGILState_Ensure`` at ``address``.")
#: ``void PyGILState_Release(PyGILState_STATE)``
gil_release_at = _function_at(types.FunctionType(types.void(types.intc)),
                              "CPython's ``PyGILState_Release`` at ``address``.")
#: ``int clock_gettime(clockid_t, struct timespec *)``, the timespec as two int64
clock_at = _function_at(types.FunctionType(types.intc(types.intc, types.CPointer(types.int64))),
                        "The C library's ``clock_gettime`` at ``address``.")


def watch_addresses() -> tuple[int, int, int, int]:
    """The addresses of ``PyOS_InterruptOccurred``, ``clock_gettime``, ``PyGILState_Ensure``
    and ``PyGILState_Release`` in this process (``0`` for a C library without
    ``clock_gettime``: the kernel then cannot keep a wall-clock limit, and the caller must
    not ask it to)."""
    api = ctypes.pythonapi
    try:
        clock = ctypes.cast(ctypes.CDLL(None).clock_gettime, ctypes.c_void_p).value or 0
    except (AttributeError, OSError, TypeError):
        clock = 0

    interrupted, ensure, release = (ctypes.cast(f, ctypes.c_void_p).value or 0 for f in (
        api.PyOS_InterruptOccurred, api.PyGILState_Ensure, api.PyGILState_Release))
    return interrupted, clock, ensure, release


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
