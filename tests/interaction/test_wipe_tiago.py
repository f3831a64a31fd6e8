"""tiago_wipe (5.3.3): TIAGo presses a table with 10 N while its hand slides 30 cm along it.
Short runs by default (2.5 s: the contact, the force ramp, and the first half of the stroke,
which holds its fastest part), full runs marked slow. Acceptance: the normal-force RMS error
after 1 s under 5 % of 10 N, the tangential path error under 5 mm."""

from __future__ import annotations

import pytest

from tests.helpers.wipe import assert_accepted, figures, wipe


@pytest.mark.parametrize("source", ["simulator", "observer"])
def test_tiago_wipe_short_meets_the_acceptance(source):
    m = wipe("tiago_wipe", source=source, duration=2.5)
    assert_accepted(m, "tiago_wipe", stroke=0.14)


def test_tiago_wipe_the_integral_removes_a_constant_force_bias():
    """5 N of unmodelled downward force on the hand: without integral action the contact
    force stays off (the P term only divides the bias by 1 + K_P, part of it taken by the
    motion tasks), with it the error after 1 s is a few mN."""
    without = figures(wipe("tiago_wipe", integral=False, bias=5.0, duration=1.5))
    with_ = figures(wipe("tiago_wipe", bias=5.0, duration=1.5))
    assert without["normal_force_mean"] - 10.0 > 0.5                  # > 5 % off
    assert with_["normal_force_rms_error"] < 0.05 and abs(with_["normal_force_mean"] - 10.0) < 0.02


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["hqp", "weighted"])
@pytest.mark.parametrize("source", ["simulator", "observer"])
def test_tiago_wipe_full(solver, source):
    assert_accepted(wipe("tiago_wipe", source=source, solver=solver), "tiago_wipe", stroke=0.29)
