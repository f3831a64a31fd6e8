"""tiago_glass (5.3.5): TIAGo drives with a glass in its hand, 30 N on the elbow from 1.5 s
to 2.5 s. Selective compliance keeps the glass (tilt < 2°, hand < 1 cm) while the elbow
yields (> 3 cm); one joint impedance everywhere tilts it (> 10°). Short runs (through the
push) by default; the full runs, the observer's estimate and MuJoCo are marked slow."""

from __future__ import annotations

import pytest

from .glass_common import TEN_DEG, TWO_DEG, assert_clean, glass_run

PUSH_END = 2.6      # s: the push acts from 1.5 s to 2.5 s


def check_selective(m: dict, tilt: float = TWO_DEG, hand: float = 0.01) -> None:
    assert_clean(m)
    assert m["glass_tilt_max"] < tilt
    assert m["hand_position_error_max"] < hand
    assert m["elbow_displacement_max"] > 0.03
    assert m["base_lateral_velocity_max"] < 1e-6          # the differential drive holds


def test_tiago_glass_keeps_the_glass_while_the_elbow_yields():
    m = glass_run("tiago_glass", duration=PUSH_END)
    check_selective(m, tilt=0.2 * TWO_DEG, hand=1e-3)       # the true push: 0.04°, 0.06 mm measured
    assert m["push_estimate"]["error_rel"] < 0.01            # the observer, reported alongside


def test_tiago_glass_without_selective_compliance_tilts_the_glass():
    m = glass_run("tiago_glass_compliant", duration=PUSH_END)
    assert_clean(m)
    assert m["glass_tilt_max"] > TEN_DEG


@pytest.mark.slow
@pytest.mark.parametrize("simulator", ["pinocchio", "mujoco"])
@pytest.mark.parametrize("solver", ["hqp", "projection", "weighted"])
def test_tiago_glass_full_run(solver, simulator):
    check_selective(glass_run("tiago_glass", solver=solver, simulator=simulator))


@pytest.mark.slow
@pytest.mark.parametrize("simulator", ["pinocchio", "mujoco"])
def test_tiago_glass_with_the_momentum_observers_estimate(simulator):
    check_selective(glass_run("tiago_glass_observer", simulator=simulator))


@pytest.mark.slow
@pytest.mark.parametrize("simulator", ["pinocchio", "mujoco"])
def test_tiago_glass_compliant_full_run(simulator):
    m = glass_run("tiago_glass_compliant", simulator=simulator)
    assert_clean(m)
    assert m["glass_tilt_max"] > TEN_DEG
