"""A sweep on a Dask cluster on this machine (``distributed.LocalCluster``, two workers).

The same ``hybridlab.sweep`` call as on a process pool, with a
``distributed.Client`` as the executor: 12 runs of ``models/bouncing_ball.toml``
over the restitution ``e`` and the drop height ``h``, counting bounces and
recording the final speed. For several machines, start ``dask scheduler`` and
``dask worker`` processes and pass ``Client("tcp://HOST:8786")`` instead (see
``docs/sweeps.md``, "Dask: more than one machine").

Checks that the cluster had two workers, that every run completed and that
the table equals the same sweep run serially in this process.

Dask is optional (the ``dask`` extra: ``pip install 'hybridlab[dask]'``).
Without it the script runs the serial sweep only, says that it skipped the
cluster, and exits 0.

Usage::

    python examples/sweep_dask_local.py [--plot FILE.png]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

import hybridlab
from hybridlab.ensemble import Count

MODEL = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"
SWEEP = {
    "grid": {"e": [0.8, 0.85, 0.9, 0.95], "h": [5.0, 10.0, 20.0]},
    "t_end": 6.0,
    "observe": {"v_end": "v", "top": ("max", "h")},
    "events": ["bounce", Count("bounce", after="bounce", name="later")],
}


def on_local_cluster(model, workers: int = 2) -> hybridlab.SweepResult:
    """The sweep on a ``LocalCluster`` of ``workers`` single-threaded worker processes."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      host="127.0.0.1", dashboard_address=None) as cluster, \
            Client(cluster) as client:
        table = hybridlab.sweep(model, executor=client, **SWEEP)
        running = len(client.scheduler_info()["workers"])
    print(f"Dask: {len(table)} runs on {running} workers ({table.executor}) "
          f"in {table.elapsed:.2f} s")
    if running != workers:
        print(f"FAIL: the cluster had {running} workers, not {workers}")
        raise SystemExit(1)
    return table


def plot(table: hybridlab.SweepResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pivot = table.pivot("e", "h", "count:bounce")
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for k, h in enumerate(pivot.columns):
        ax.plot(pivot.index, pivot.values[:, k], "o-", ms=3, label=f"dropped from {h:g} m")
    ax.set(xlabel="restitution e", ylabel="bounces in 6 s",
           title=f"Bounces in a sweep ({table.executor})")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", type=Path, help="write bounces against e here")
    args = parser.parse_args(argv)

    model = hybridlab.load_model(MODEL)
    serial = hybridlab.sweep(model, executor="serial", **SWEEP)
    print(f"serial: {len(serial)} runs in {serial.elapsed:.2f} s")
    ok = serial.ok
    table = serial
    if importlib.util.find_spec("distributed") is None:
        print("distributed is not installed (pip install 'hybridlab[dask]'): "
              "skipped the local cluster")
    else:
        table = on_local_cluster(model)
        same = table.columns == serial.columns and table.rows == serial.rows
        print(f"the cluster's table equals the serial one: {same}")
        ok = ok and table.ok and same
    if not ok:
        print(f"FAIL: runs that did not complete: {table.failed}")
    if args.plot:
        plot(table, args.plot)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
