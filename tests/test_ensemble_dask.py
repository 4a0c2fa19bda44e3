"""A sweep on a Dask ``LocalCluster`` (loopback, two worker processes) equals the serial one."""

from __future__ import annotations

from pathlib import Path

import pytest

import hybridlab
from hybridlab.ensemble import Count, sweep

distributed = pytest.importorskip("distributed", reason="distributed (extra 'dask') not installed")

BALL = Path(__file__).resolve().parents[1] / "models" / "bouncing_ball.toml"


def test_sweep_on_a_local_cluster_equals_the_serial_sweep():
    model = hybridlab.load_model(BALL)
    kwargs = {"grid": {"e": [0.7, 0.8, 0.9], "h": [4.0, 8.0]}, "t_end": 3.0,
              "observe": {"v_end": "v", "top": ("max", "h")},
              "events": ["bounce", Count("bounce", after="bounce")], "chunksize": 2,
              # fresh worker processes: the reference backend spares each a numba cache load,
              # which keeps this test well inside its time budget on a busy machine
              "backend": "reference"}
    serial = sweep(model, executor="serial", **kwargs)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        on_dask = sweep(model, executor=client, **kwargs)
        workers = client.run(lambda: 1)
    assert len(workers) == 2
    assert on_dask.executor == "dask(2)"
    assert on_dask.columns == serial.columns
    assert on_dask.rows == serial.rows
    assert serial.ok and len(serial) == 6
