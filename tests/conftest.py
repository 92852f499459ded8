"""Shared fixtures: one Drake scene per session (building is cheap, importing pydrake is not)."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import pytest

from pih.scene.config import SceneConfig
from pih.scene.simulation import PegInHoleScene


@pytest.fixture(scope="session")
def scene() -> PegInHoleScene:
    return PegInHoleScene(SceneConfig())
