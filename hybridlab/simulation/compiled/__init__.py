"""The compiled simulation backend (numba; the ``fast`` extra).

The model's flows, guards, invariants, switching functions, Lie derivatives
and resets are printed to a generated module (:mod:`.codegen`), and a numba
kernel (:mod:`.integrate`, :mod:`.locate`, :mod:`.kernel`) runs the
integrator steps, the dense output, the event location and the common jump
logic in machine code. :mod:`.backend` builds the usual
:class:`~hybridlab.SimulationResult`. Nothing here is imported unless a
simulation uses the compiled backend.
"""

from __future__ import annotations

import importlib.util

from hybridlab.errors import SimulationError

__all__ = ["numba_available", "use_compiled"]


def numba_available() -> bool:
    """Whether numba can be imported (the ``fast`` extra is installed).

    Examples
    --------
    >>> isinstance(numba_available(), bool)
    True
    """
    return importlib.util.find_spec("numba") is not None


def use_compiled(backend: str) -> bool:
    """Whether a simulation with option ``backend`` runs on the compiled backend.

    Raises
    ------
    hybridlab.SimulationError
        For ``backend="compiled"`` when numba is not installed.

    Examples
    --------
    >>> use_compiled("reference")
    False
    """
    if backend == "reference":
        return False
    available = numba_available()
    if backend == "compiled" and not available:
        raise SimulationError("backend='compiled' needs numba: pip install 'hybridlab[fast]' "
                              "(or use backend='auto' or 'reference')")
    return available
