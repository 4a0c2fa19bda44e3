"""The mode graph of a model as a networkx multigraph, and DOT export."""

from __future__ import annotations

import networkx as nx

from hybridlab.model.schema import Model

__all__ = ["mode_graph", "to_dot"]


def mode_graph(model: Model) -> nx.MultiDiGraph:
    """Modes as nodes, transitions as edges (keyed by transition name).

    Node attributes: ``flow``, ``invariant``, ``initial``. Edge attributes:
    ``name``, ``guard``, ``reset``, ``priority``, ``schedule``.

    Examples
    --------
    >>> import hybridlab
    >>> g = mode_graph(hybridlab.load_model("models/thermostat.toml"))
    >>> sorted(g.edges(keys=True))
    [('cool', 'heat', 'turn_on'), ('heat', 'cool', 'turn_off')]
    """
    graph = nx.MultiDiGraph(name=model.name)
    for name, mode in model.modes.items():
        graph.add_node(name, flow=dict(mode.flow), invariant=list(mode.invariant),
                       initial=name == model.initial.mode)
    for tr in model.symbolic.transitions:
        declared = model.transitions[tr.declared]
        schedule = (f"every {declared.schedule.period} from {declared.schedule.phase}"
                    if declared.schedule else "")
        graph.add_edge(tr.source, tr.target, key=tr.name, name=tr.name,
                       guard=" and ".join(declared.guard), reset=dict(declared.reset),
                       priority=tr.priority, schedule=schedule)
    return graph


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def to_dot(model: Model) -> str:
    """The mode graph in Graphviz DOT, with guards and resets on the edges.

    Examples
    --------
    >>> import hybridlab
    >>> print(to_dot(hybridlab.load_model("models/bouncing_ball.toml")).splitlines()[0])
    digraph "bouncing_ball" {
    """
    graph = mode_graph(model)
    lines = [f"digraph {_quote(model.name)} {{", "  rankdir=LR;"]
    for node, data in graph.nodes(data=True):
        flow = "\n".join(f"{k}' = {v}" for k, v in data["flow"].items())
        shape = "doublecircle" if data["initial"] else "ellipse"
        label = node + ("\n" + flow if flow else "")
        lines.append(f"  {_quote(node)} [shape={shape}, label={_quote(label)}];")
    for u, v, data in graph.edges(data=True):
        parts = [data["name"]]
        if data["guard"]:
            parts.append(f"[{data['guard']}]")
        if data["schedule"]:
            parts.append(f"({data['schedule']})")
        parts.extend(f"{k} := {e}" for k, e in data["reset"].items())
        lines.append(f"  {_quote(u)} -> {_quote(v)} [label={_quote(' '.join(parts))}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
