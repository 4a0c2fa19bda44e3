"""Static checks of a mode graph: a guard that can never fire, a dead mode, a zero-dwell cycle.

Run ``python examples/mode_graph_check.py [--plot FILE.png]``. Exits with status 1 if a
check does not find what it should.
"""

from __future__ import annotations

import argparse
import sys

import hybridlab
from hybridlab.graph import Feasibility, Severity, check_mode_graph

# A valve that opens and closes on a pressure threshold. Three deliberate mistakes:
# - "vent" needs p >= 12 but the invariant of "open" keeps p <= 10: it can never fire,
#   so "venting" is dead;
# - "open" and "close" share the threshold 5 (no hysteresis): at p == 5 they can
#   fire back and forth at a single instant, a zero-dwell (Zeno) cycle.
VALVE = """
name = "valve"
[parameters]
p_on = 5.0
p_off = 5.0
[states]
p = 0.0
[modes.closed]
flow = { p = "1" }
[modes.open]
flow = { p = "-1" }
invariant = "p <= 10"
[modes.venting]
flow = { p = "-5" }
[[transitions]]
name = "open"
source = "closed"
target = "open"
guard = "p >= p_on"
[[transitions]]
name = "close"
source = "open"
target = "closed"
guard = "p <= p_off"
[[transitions]]
name = "vent"
source = "open"
target = "venting"
guard = "p >= 12"
[initial]
mode = "closed"
[scenarios.hysteresis]
t_end = 10.0
parameters = { p_off = 4.0 }
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE.png", help="draw the mode graph, dead modes grey")
    args = parser.parse_args()

    model = hybridlab.loads_model(VALVE)
    report = check_mode_graph(model)
    print(report)
    vent = next(t for t in report.transitions if t.name == "vent")
    [cycle] = report.cycles
    # with hysteresis alone (only the scenario's parameters) the cycle is impossible
    fixed = check_mode_graph(model, scenarios=["hysteresis"])
    print()
    print(fixed)

    failures = [text for ok, text in [
        (vent.guard is Feasibility.IMPOSSIBLE, "'vent' should never fire"),
        (report.dead_modes == ("venting",), "'venting' should be dead"),
        # possible with the model's values (p_on == p_off): a warning
        (cycle.verdict is Feasibility.POSSIBLE and cycle.parameter_set == "model values",
         "open -> close should be a zero-dwell cycle"),
        (fixed.cycles[0].verdict is Feasibility.IMPOSSIBLE, "hysteresis should rule the cycle out"),
        (fixed.count(Severity.WARNING) == 1, "only the dead mode should remain a warning"),
    ] if not ok]
    for text in failures:
        print(f"FAILED: {text}", file=sys.stderr)
    if args.plot:
        plot(model, report, args.plot)
        print(f"wrote {args.plot}")
    return 1 if failures else 0


def plot(model: hybridlab.Model, report: hybridlab.graph.GraphReport, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import networkx as nx

    graph = hybridlab.mode_graph(model)
    never = {(t.source, t.target) for t in report.transitions if t.guard is Feasibility.IMPOSSIBLE}
    pos = nx.circular_layout(graph)
    fig, ax = plt.subplots(figsize=(5, 4))
    colors = ["lightgrey" if n in report.dead_modes else "lightblue" for n in graph.nodes]
    nx.draw_networkx_nodes(graph, pos, node_color=colors, node_size=1800, ax=ax)
    nx.draw_networkx_labels(graph, pos, ax=ax)
    edges = list(graph.edges())
    nx.draw_networkx_edges(graph, pos, edgelist=edges, ax=ax, node_size=1800,
                           connectionstyle="arc3,rad=0.15",
                           style=["dashed" if e in never else "solid" for e in edges])
    ax.set_title("valve: dashed = never fires, grey = dead")
    ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
