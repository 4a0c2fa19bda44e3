"""Mode-graph analysis: the mode graph (networkx), DOT export and static checks.

:func:`mode_graph` and :func:`to_dot` draw the graph; :func:`check_mode_graph`
finds dead modes, guards that never hold, resets that always leave the target
invariant, sink modes and zero-dwell cycles (see ``docs/mode-graph.md``).
"""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.graph._dot import mode_graph, to_dot
    from hybridlab.graph.check import (
        CycleCheck,
        Finding,
        GraphReport,
        Severity,
        TransitionCheck,
        check_mode_graph,
    )
    from hybridlab.graph.feasibility import Decision, Feasibility, decide

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "CycleCheck",
    "Decision",
    "Feasibility",
    "Finding",
    "GraphReport",
    "Severity",
    "TransitionCheck",
    "check_mode_graph",
    "decide",
    "mode_graph",
    "to_dot",
]
