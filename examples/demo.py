"""The ``make demo`` target: bouncing ball (default and Zeno runs) and thermostat.

Simulates ``models/bouncing_ball.toml`` (scenarios ``default`` and ``zeno``)
and ``models/thermostat.toml`` (scenario ``default``), prints a short
summary of each run and writes one figure with the three trajectories.

Run ``python examples/demo.py [--plot FILE]`` (default ``demo.png``). Exits
with status 1 if a run does not end as expected: the default ball and the
thermostat reach ``t_end``; the Zeno ball stops with status ``ZENO`` at the
accumulation time 12.8506 s.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import hybridlab

MODELS = Path(__file__).resolve().parents[1] / "models"


def summary(title: str, result: hybridlab.SimulationResult) -> str:
    final = result.final
    state = ", ".join(f"{name} = {value:.6g}" for name, value in final.state.items())
    lines = [f"{title}",
             f"  status   {result.status.name}: {result.message}",
             f"  events   {len(result.events)} ({len(result.jumps)} jumps)",
             f"  final    t = {final.t:.6g}, j = {final.j}, mode {final.mode}: {state}"]
    if result.zeno_time is not None:
        lines.append(f"  zeno at  t = {result.zeno_time:.10g}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", metavar="FILE", default="demo.png",
                        help="where to write the figure (default: demo.png)")
    args = parser.parse_args(argv)

    ball = hybridlab.load_model(MODELS / "bouncing_ball.toml")
    runs = {
        "bouncing ball, scenario default (t_end = 10 s)": hybridlab.simulate(ball),
        "bouncing ball, scenario zeno (t_end = 20 s)": hybridlab.simulate(ball, scenario="zeno"),
        "thermostat, scenario default (t_end = 60 min)":
            hybridlab.simulate(MODELS / "thermostat.toml"),
    }
    for title, result in runs.items():
        print(summary(title, result))
    default, zeno, thermostat = runs.values()
    ok = (default.status is hybridlab.Status.COMPLETED
          and thermostat.status is hybridlab.Status.COMPLETED
          and zeno.status is hybridlab.Status.ZENO
          and zeno.zeno_time is not None and abs(zeno.zeno_time - 12.8506) < 1e-4)

    plot(runs, args.plot)
    print(f"wrote {args.plot}")
    if not ok:
        print("FAILED: a run did not end as expected")
    return 0 if ok else 1


def plot(runs: dict[str, hybridlab.SimulationResult], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(8, 8))
    axis_labels = [("h", "m", "s"), ("h", "m", "s"), ("T", "degC", "min")]
    for ax, (title, result), (name, unit, time_unit) in zip(axes, runs.items(), axis_labels,
                                                            strict=True):
        t, y = result.sample(min(0.005, result.final.t / 2000))
        ax.plot(t, y[result.state_names.index(name)], lw=1)
        for event in result.jumps:
            ax.axvline(event.t, color="0.8", lw=0.5, zorder=0)
        if result.zeno_time is not None:
            ax.axvline(result.zeno_time, color="r", ls="--", lw=1,
                       label=f"Zeno: t = {result.zeno_time:.4f}")
            ax.legend(loc="upper right")
        ax.set_title(f"{title}: {result.status.name}", fontsize=10)
        ax.set(xlabel=f"t [{time_unit}]", ylabel=f"{name} [{unit}]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
