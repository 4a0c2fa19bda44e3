"""Mode-graph analysis: the mode graph (networkx), DOT export and static checks."""

from hybridlab.graph._dot import mode_graph, to_dot

__all__ = ["mode_graph", "to_dot"]
