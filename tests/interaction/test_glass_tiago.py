"""tiago_glass (5.3.5): TIAGo drives with a glass in its hand, 30 N on the elbow from 1.5 s
to 2.5 s. Selective compliance keeps the glass (tilt < 2°, hand < 1 cm) while the elbow
yields (> 3 cm); one joint impedance everywhere tilts it (> 10°). Short runs (through the
push) here; the full runs are tests/interaction/test_glass_full.py, marked slow."""

from __future__ import annotations

from tests.helpers.glass_common import TEN_DEG, TWO_DEG, assert_clean, check_selective, glass_run

PUSH_END = 2.6      # s: the push acts from 1.5 s to 2.5 s


def test_tiago_glass_keeps_the_glass_while_the_elbow_yields():
    m = glass_run("tiago_glass", duration=PUSH_END)
    check_selective(m, tilt=0.2 * TWO_DEG, hand=1e-3)       # the true push: 0.04°, 0.06 mm measured
    assert m["push_estimate"]["error_rel"] < 0.01            # the observer, reported alongside


def test_tiago_glass_without_selective_compliance_tilts_the_glass():
    m = glass_run("tiago_glass_compliant", duration=PUSH_END)
    assert_clean(m)
    assert m["glass_tilt_max"] > TEN_DEG


