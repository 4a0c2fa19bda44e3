"""Shared fixtures: the bundled model files."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

import hybridlab

# CI runs the property tests on a fixed example sequence so a landing never depends on luck;
# locally each run explores new examples.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


@pytest.fixture(scope="session")
def models_dir() -> Path:
    return MODELS


@pytest.fixture(scope="session")
def ball() -> hybridlab.Model:
    return hybridlab.load_model(MODELS / "bouncing_ball.toml")


@pytest.fixture(scope="session")
def spaceex_proof():
    """``prove(xml, cfg)``: the verdict on a bundled SpaceEx benchmark with its ``.cfg``'s
    specs, initial set and horizon and otherwise default options (the step is hybridlab's own,
    as in ``benchmarks/reach/run.py``), asserted SAFE."""
    from hybridlab.io import load_spaceex
    from hybridlab.verify import check_safety

    def prove(xml: str, cfg: str):
        problem = load_spaceex(MODELS / "spaceex" / xml, MODELS / "spaceex" / cfg)
        kwargs = problem.reach_kwargs()
        kwargs.pop("step", None)
        verdict = check_safety(problem.model, safe=problem.safe_specs(), **kwargs)
        assert verdict.status.name == "SAFE", verdict.reason
        return verdict

    return prove


@pytest.fixture(params=["compiled", "reference"])
def each_engine(request, monkeypatch) -> str:
    """Run the requesting test on both engines (compiled only when numba is installed).

    A test that chooses its engine itself (a ``backend`` argument) runs once.
    """
    if "backend" in request.fixturenames:
        if request.param == "reference":
            pytest.skip("the test chooses its engine itself")
        return "own"
    if request.param == "compiled":
        pytest.importorskip("numba")
    import hybridlab.simulation.api as api

    monkeypatch.setattr(api, "use_compiled", lambda _: request.param == "compiled")
    return str(request.param)
