"""Every rule of event handling and every op code is stated in one module.

Both engines and the hybrid layer of reachability import them from
``hybridlab/simulation/rules.py`` and ``compiled/opcodes.py``; these tests read the
sources and fail when a copy creeps back in.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import hybridlab
from hybridlab.simulation import rules

PACKAGE = Path(hybridlab.__file__).parent
SEMANTICS = [*sorted((PACKAGE / "simulation").rglob("*.py")),
             PACKAGE / "reachability" / "hybrid.py"]


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _assigned_names(tree: ast.Module) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                for leaf in ast.walk(target):
                    if isinstance(leaf, ast.Name):
                        names.add(leaf.id)
    return names


def _mentions_time_tolerance(node: ast.AST) -> bool:
    text = ast.unparse(node)
    return "xtol" in text or "event_tol" in text or text == "xt"


@pytest.mark.parametrize("path", SEMANTICS, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_restates_a_rule(path):
    if path.name == "rules.py":
        return
    tree = _tree(path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and node.value == rules.CHECK_AT:
            pytest.fail(f"{path.name}:{node.lineno} restates the sampling split")
        # the index of a scheduled instant
        if isinstance(node, ast.Call) and ast.unparse(node.func) in ("math.ceil", "ceil") \
                and "period" in ast.unparse(node):
            pytest.fail(f"{path.name}:{node.lineno} restates the schedule index: "
                        f"{ast.unparse(node)}")
        # an equivalent sign leaving [-1, 1]
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add) \
                and isinstance(node.left, ast.Constant) and node.left.value == 1 \
                and isinstance(node.right, ast.Constant):
            pytest.fail(f"{path.name}:{node.lineno} restates a slack: {ast.unparse(node)}")
        # a band or width written as a number times an event tolerance
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
            for number, other in ((node.left, node.right), (node.right, node.left)):
                if isinstance(number, ast.Constant) and number.value in (2, 4, 8, 16) \
                        and _mentions_time_tolerance(other):
                    pytest.fail(f"{path.name}:{node.lineno} restates a band: "
                                f"{ast.unparse(node)}")


def test_op_codes_are_assigned_only_in_opcodes():
    owners = [path.name for path in sorted((PACKAGE / "simulation" / "compiled").glob("*.py"))
              if any(name.startswith("OP_") for name in _assigned_names(_tree(path)))]
    assert owners == ["opcodes.py"]


def test_the_compiled_kernel_reads_the_rules():
    numba = pytest.importorskip("numba")
    from hybridlab.simulation.compiled import kernel, locate

    assert isinstance(locate.xtol_at, numba.core.registry.CPUDispatcher)
    assert locate.xtol_at(1e-12, -300.0) == rules.event_time_tolerance(1e-12, -300.0)
    for t, phase, period, done in ((2.0 - 1e-12, 0.0, 1.0, -1), (2.5, 0.1, 0.2, 20),
                                   (-1.0, 0.0, 0.5, -1)):
        assert kernel._sched_index(t, phase, period, done) == rules.schedule_index(
            t, phase, period, done)
