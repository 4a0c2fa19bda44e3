"""Shared fixtures: the bundled model files."""

from __future__ import annotations

from pathlib import Path

import pytest

import hybridlab

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


@pytest.fixture(scope="session")
def models_dir() -> Path:
    return MODELS


@pytest.fixture(scope="session")
def ball() -> hybridlab.Model:
    return hybridlab.load_model(MODELS / "bouncing_ball.toml")
