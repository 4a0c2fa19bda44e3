"""The operation codes of a generated model function, shared by the code generator and the
kernel.

A generated model is one C-callable ``model(op, group, t, x, p, sigma, f, out)``
(:data:`~hybridlab.simulation.compiled.signatures.MODEL_SIGNATURE`); ``op`` says what it
writes to ``out`` and ``group`` which rows (a mode's flow, a transition's guard, ...).

>>> from hybridlab.simulation.compiled import opcodes
>>> opcodes.OP_FLOW, opcodes.OP_GUARD, opcodes.N_OPS
(0, 6, 16)
"""

from __future__ import annotations

__all__ = ["OP_FLOW", "OP_COND", "OP_COND_LIE", "OP_SWITCH", "OP_SWITCH_LIE", "OP_RESET",
           "OP_GUARD", "OP_GUARD_LIE", "OP_SWITCH_GRAD", "OP_FLOW_DSIGMA", "OP_SLIDE_PARTS",
           "OP_COND_BOTH", "OP_SWITCH_BOTH", "OP_GUARD_BOX", "OP_INV_BOX", "OP_SWITCH_BOX",
           "N_OPS"]

#: a mode's flow; condition rows (guards and invariants of a mode) and their Lie derivatives;
#: switching functions and their Lie derivatives; a transition's reset, its guard rows and
#: their Lie derivatives
OP_FLOW, OP_COND, OP_COND_LIE, OP_SWITCH, OP_SWITCH_LIE, OP_RESET, OP_GUARD, OP_GUARD_LIE = \
    range(8)
#: sliding only: ``out[k*n + i] = d s_k / d x_i`` and ``out[i*m + k] = d f_i / d sigma_k``
OP_SWITCH_GRAD, OP_FLOW_DSIGMA = 8, 9
#: fused (one call, shared subexpressions): the flow, the switches' Lie derivatives along it,
#: their gradient and the flow's sigma-Jacobian (``[f | ds/dt | grad | dsigma]``, per mode);
#: condition values and Lie derivatives (``[g | dg/dt]``, cond groups); switch values and
#: Lie derivatives (``[s | ds/dt]``, switch groups)
OP_SLIDE_PARTS, OP_COND_BOTH, OP_SWITCH_BOTH = 10, 11, 12
#: enclosures over a box, ``out = [lower | upper]``: a transition's guard rows (the groups of
#: OP_GUARD), a mode's invariants (groups of their own) and its switching functions (the
#: groups of OP_SWITCH)
OP_GUARD_BOX, OP_INV_BOX, OP_SWITCH_BOX = 13, 14, 15
#: how many operations there are
N_OPS = 16
