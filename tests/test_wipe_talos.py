"""talos_wipe (5.3.3): Talos, on both feet, presses a table with 10 N while its hand slides
30 cm along it. A short run by default (2.5 s: the contact, the force ramp, the first half of
the stroke, with its fastest part), full runs marked slow; acceptance as tiago_wipe's."""

from __future__ import annotations

import pytest

from wbc.scenario import load_config

from .wipe import figures, wipe

ACCEPT = load_config("talos_wipe").acceptance


def _accepted(m: dict, stroke: float) -> None:
    f = figures(m)
    assert not m["fell"] and m["solver_failures"] == 0 and m["saturated_cycles"] == 0
    assert sum(m["violations"].values()) == 0, m["violations"]
    assert f["contact_lost_cycles"] == 0
    assert m["normal_force_rms_error"] < ACCEPT["normal_force_rms_error"]
    assert m["path_error_max"] < ACCEPT["path_error_max"]
    assert f["slide_length"] > stroke
    assert all(not c["lifted"] and c["slip"] < 1e-3 for c in m["contacts"].values())    # the feet


def test_talos_wipe_short_meets_the_acceptance():
    _accepted(wipe("talos_wipe", duration=2.5), stroke=0.14)


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["hqp", "weighted"])
@pytest.mark.parametrize("source", ["simulator", "observer"])
def test_talos_wipe_full(solver, source):
    _accepted(wipe("talos_wipe", source=source, solver=solver), stroke=0.29)


@pytest.mark.slow
def test_talos_wipe_the_integral_removes_a_constant_force_bias():
    without = figures(wipe("talos_wipe", integral=False, bias=5.0))
    with_ = figures(wipe("talos_wipe", bias=5.0))
    assert without["normal_force_mean"] - 10.0 > 0.5
    assert with_["normal_force_rms_error"] < 0.05
