"""The compiled loop that runs interval programs gives the Python run's numbers, bit for bit."""

from __future__ import annotations

import inspect
import math
import re

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("numba")

from hybridlab.symbolic import interval_arithmetic as ia  # noqa: E402
from hybridlab.symbolic import interval_machine  # noqa: E402
from hybridlab.symbolic.interval_machine import OPS, CompiledProgram, _run  # noqa: E402
from hybridlab.symbolic.intervals import (  # noqa: E402
    COMPILE_AFTER,
    EmptyInterval,
    Instruction,
    IntervalFunction,
    IntervalProgram,
)

x, y, z = sp.symbols("x y z", real=True)

#: expressions that between them use every instruction the lowering emits
EVERY_OP = [
    x + y - z, x * y, x / (y + 3), sp.Min(x, y) + sp.Max(y, z), sp.atan2(y, x + 3),
    (x + 2) ** (y + 1), x**3 + x ** sp.Rational(1, 3) * 0 + (x + 2) ** 1.5, -x,
    1 / (x + 3), sp.sqrt(x + 2), 1 / sp.sqrt(x + 2), sp.exp(x), sp.log(x + 2), sp.sin(x),
    sp.cos(y), sp.tan(z / 4), sp.asin(x / 3), sp.acos(y / 3), sp.atan(z), sp.sinh(x),
    sp.cosh(y), sp.tanh(z), sp.Abs(x - y), sp.sign(y), sp.Heaviside(z),
    sp.pi * x + sp.Rational(1, 3), sp.Float(0.1) * y,
]


def _python(program: IntervalProgram, lo: np.ndarray, hi: np.ndarray) -> list[tuple]:
    vals = program.run(list(zip(lo.tolist(), hi.tolist(), strict=True)))
    return [vals[k] for k in program.outputs]


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def test_the_loop_has_one_branch_per_op_of_the_table_in_its_order():
    calls = re.findall(r"op == (\d+):\n\s+r = (i_\w+)", inspect.getsource(_run))
    assert [(int(code), name) for code, name in calls] == [
        (code, name) for code, (name, _) in enumerate(OPS)]


def test_the_table_names_every_operation_the_lowering_emits():
    emitted = {ins.op for e in EVERY_OP for ins in IntervalProgram.of([e], [x, y, z])
               .instructions}
    assert emitted <= {name for name, _ in OPS}
    assert {name for name, _ in OPS} <= set(ia.__all__)
    # every table entry is exercised below: these three by hand-made instructions
    assert {name for name, _ in OPS} - emitted <= {"i_entire", "i_empty", "i_div"}


def _every_op_program() -> IntervalProgram:
    program = IntervalProgram.of(EVERY_OP, [x, y, z])
    for op, args in (("i_div", (0, 1)), ("i_entire", ()), ("i_empty", ())):
        program.instructions.append(Instruction(op, args))
        program.outputs.append(program.n_args + len(program.instructions) - 1)
    return program


box = st.tuples(st.floats(-2.0, 2.0), st.floats(0.0, 1.5)).map(lambda t: (t[0], t[0] + t[1]))


@settings(max_examples=60, deadline=None)
@given(bx=box, by=box, bz=box)
def test_every_instruction_gives_the_python_numbers_bit_for_bit(bx, by, bz):
    program = _every_op_program()
    lo = np.array([bx[0], by[0], bz[0]])
    hi = np.array([bx[1], by[1], bz[1]])
    expected = _python(program, lo, hi)
    slots_lo = np.empty(program.n_args + len(program.instructions))
    slots_hi = np.empty_like(slots_lo)
    slots_lo[:3], slots_hi[:3] = lo, hi
    compiled = CompiledProgram(program)
    interval_machine._RUN(compiled.code, compiled.first, compiled.second, compiled.ints,
                          compiled.consts, slots_lo, slots_hi, program.n_args)
    for k, (e_lo, e_hi) in zip(program.outputs, expected, strict=True):
        assert _same(slots_lo[k], e_lo) and _same(slots_hi[k], e_hi), program.instructions


def test_a_lenient_program_with_the_whole_line_runs_compiled_too():
    program = IntervalProgram.of([x + sp.Function("g")(y)], [x], lenient=True)
    lo, hi = CompiledProgram(program)(np.array([0.0]), np.array([1.0]))
    assert (lo[0], hi[0]) == (-math.inf, math.inf)


def test_an_interval_function_switches_to_the_loop_and_keeps_its_numbers():
    f = IntervalFunction([x * sp.sin(y) + sp.exp(x) * y**2, sp.sqrt(x + 1)], [x, y])
    lo, hi = np.array([0.1, -1.0]), np.array([0.7, 2.0])
    python = [f(lo, hi) for _ in range(COMPILE_AFTER - 1)]
    assert f._compiled is None                     # still in Python
    compiled = f(lo, hi)
    assert isinstance(f._compiled, CompiledProgram)
    assert all(np.array_equal(a, b) for a, b in zip(python[0], compiled, strict=True))


def test_an_empty_result_raises_the_python_error_from_the_loop_too():
    f = IntervalFunction([sp.sqrt(x)], [x])
    for _ in range(COMPILE_AFTER + 1):
        f(np.array([0.0]), np.array([1.0]))
    assert isinstance(f._compiled, CompiledProgram)
    with pytest.raises(EmptyInterval, match="sqrt of a negative interval"):
        f(np.array([-2.0]), np.array([-1.0]))


def test_bad_bounds_are_named_by_the_loop_s_caller_as_before():
    f = IntervalFunction([x + 1], [x])
    for _ in range(COMPILE_AFTER + 1):
        f(np.array([0.0]), np.array([1.0]))
    with pytest.raises(ValueError, match=r"lo <= hi \(got \[1.0, 0.0\]\)"):
        f(np.array([1.0]), np.array([0.0]))


def test_without_numba_every_call_runs_in_python(monkeypatch):
    from hybridlab.symbolic import intervals

    monkeypatch.setattr(intervals, "_machine", lambda: None)
    f = IntervalFunction([x * y], [x, y])
    for _ in range(COMPILE_AFTER + 3):
        lo, hi = f(np.array([1.0, 2.0]), np.array([2.0, 3.0]))
    assert f._compiled is None and lo[0] <= 2.0 and hi[0] >= 6.0
