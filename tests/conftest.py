"""Shared fixtures: robots are loaded once per session (URDF parsing is the slow part)."""

from __future__ import annotations

import numpy as np
import pytest

import wbc


@pytest.fixture(scope="session")
def talos() -> wbc.RobotModel:
    return wbc.load_robot("talos")


@pytest.fixture(scope="session")
def tiago() -> wbc.RobotModel:
    return wbc.load_robot("tiago")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)
