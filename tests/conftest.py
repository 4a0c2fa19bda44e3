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
