"""Shared by the glass-of-water scenario tests (tests/interaction/test_glass_tiago.py, test_glass_talos.py)."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
from pathlib import Path

import pytest

from wbc.runner.loop import run
from wbc.scenario.loader import load_config

TASKS = Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios"
TWO_DEG = math.radians(2.0)
TEN_DEG = math.radians(10.0)
#: both physics back-ends, MuJoCo (the optional [mujoco] extra) skipped where it is not installed
SIMULATORS = ["pinocchio", pytest.param("mujoco", marks=pytest.mark.skipif(
    importlib.util.find_spec("mujoco") is None, reason="MuJoCo is the optional [mujoco] extra"))]


def glass_run(name: str, duration: float | None = None, solver: str | None = None, simulator: str | None = None,
              external_force: str | None = None) -> dict:
    """Run the bundled scenario ``name`` (optionally another external-force source); print its figures."""
    sc = load_config(TASKS / f"{name}.yaml")
    if external_force is not None:
        sc.interaction = dataclasses.replace(sc.interaction, external_force=external_force)
    m = run(sc, duration=duration, solver=solver, simulator=simulator)
    est = m.get("push_estimate", {})
    print(f"{name} [{m['external_force']}, {m['solver']}, {m['simulator']}]: glass tilt "
          f"{math.degrees(m['glass_tilt_max']):.2f}°, hand error {m['hand_position_error_max'] * 1e3:.2f} mm, elbow "
          f"{m['elbow_displacement_max'] * 1e2:.2f} cm, push estimate error {est.get('error_rel', float('nan')):.1e}")
    return m


def assert_clean(m: dict) -> None:
    """No fall, no solver failure, no limit violated."""
    assert not m["fell"] and m["solver_failures"] == 0
    assert sum(m["violations"].values()) == 0, m["violations"]


def check_selective(m: dict, tilt: float = TWO_DEG, hand: float = 0.01) -> None:
    """The issue's acceptance of a selective-compliance run: clean, glass tilt < ``tilt`` (rad),
    hand error < ``hand`` (m), the elbow moved > 3 cm; and the robot's own support held:
    TIAGo's differential drive (no lateral base velocity), Talos's feet (no slip, no lift)."""
    assert_clean(m)
    assert m["glass_tilt_max"] < tilt
    assert m["hand_position_error_max"] < hand
    assert m["elbow_displacement_max"] > 0.03
    if "base_lateral_velocity_max" in m:
        assert m["base_lateral_velocity_max"] < 1e-6
    for foot in ("left_foot", "right_foot"):
        if foot in m.get("contacts", {}):
            assert m["contacts"][foot]["slip"] < 1e-3 and not m["contacts"][foot]["lifted"]
