"""The glass scenarios (5.3.5) at full length, marked slow: every solver and both simulators with
the true push, the momentum observer's estimate, and the non-selective (compliant) control
that tilts the glass (> 10°). The short default versions are tests/test_glass_{tiago,talos}.py."""

from __future__ import annotations

import pytest

from tests.helpers.glass_common import SIMULATORS, TEN_DEG, assert_clean, check_selective, glass_run

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("simulator", SIMULATORS)
@pytest.mark.parametrize("solver", ["hqp", "projection", "weighted"])
@pytest.mark.parametrize("robot", ["tiago", "talos"])
def test_glass_full_run(robot, solver, simulator):
    check_selective(glass_run(f"{robot}_glass", solver=solver, simulator=simulator))


@pytest.mark.parametrize("simulator", SIMULATORS)
@pytest.mark.parametrize("robot", ["tiago", "talos"])
def test_glass_with_the_momentum_observers_estimate(robot, simulator):
    check_selective(glass_run(f"{robot}_glass_observer", simulator=simulator))


@pytest.mark.parametrize("simulator", SIMULATORS)
@pytest.mark.parametrize("robot", ["tiago", "talos"])
def test_glass_compliant_full_run(robot, simulator):
    m = glass_run(f"{robot}_glass_compliant", simulator=simulator)
    assert_clean(m)
    assert m["glass_tilt_max"] > TEN_DEG
