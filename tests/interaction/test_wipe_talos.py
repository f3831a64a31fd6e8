"""talos_wipe (5.3.3): Talos, on both feet, presses a table with 10 N while its hand slides
30 cm along it. A short run by default (2.5 s: the contact, the force ramp, the first half of
the stroke, with its fastest part), full runs marked slow; acceptance as tiago_wipe's."""

from __future__ import annotations

import pytest

from tests.helpers.wipe import assert_accepted, figures, wipe


def test_talos_wipe_short_meets_the_acceptance():
    assert_accepted(wipe("talos_wipe", duration=2.5), "talos_wipe", stroke=0.14, feet=True)


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
@pytest.mark.parametrize("source", ["simulator", "observer"])
def test_talos_wipe_full(solver, source):
    assert_accepted(wipe("talos_wipe", source=source, solver=solver), "talos_wipe", stroke=0.29, feet=True)


@pytest.mark.slow
def test_talos_wipe_the_integral_removes_a_constant_force_bias():
    without = figures(wipe("talos_wipe", integral=False, bias=5.0))
    with_ = figures(wipe("talos_wipe", bias=5.0))
    assert without["normal_force_mean"] - 10.0 > 0.5
    assert with_["normal_force_rms_error"] < 0.05
