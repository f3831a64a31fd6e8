"""The chapter demos' arm view (demos/_arm_view.py) live: the viser view of ``wbc run`` (one library
for the live view), its plate a surface, its arrows and targets overlays, drawn by the drawing
process; recorded: a Meshcat replay as before."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

import wbc

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def arm_view():
    sys.path.insert(0, str(ROOT / "demos"))
    try:
        import _arm_view

        yield _arm_view
    finally:
        sys.path.remove(str(ROOT / "demos"))


def test_live_arm_view_draws_in_the_viser_view(arm_view):
    pytest.importorskip("viser", reason="the live view needs viser")
    robot = wbc.load_robot("panda")
    view = arm_view.ArmView(robot, live=True, arrows={"contact": "contact", "push": "push"}, targets=["hand"],
                            m_per_newton=0.01, fps=30.0)
    try:
        view.plate([0.5, 0.0, 0.3], [0.0, 0.0, 1.0])
        point, force = np.array([0.5, 0.0, 0.3]), np.array([0.0, 0.0, 20.0])
        for k in range(6):
            view.draw(robot.q_default, k / 30.0, arrows={"contact": (point, force), "push": (point, np.zeros(3))},
                      targets={"hand": [0.4, 0.1, 0.5]})
        live = view.view
        assert live.url.startswith("http://127.0.0.1:")
        snap = live.latest()
        (seg,) = snap.overlays["forces"]["arrows"]             # the push (0 N) is not drawn
        np.testing.assert_allclose(seg, [point, point + 0.01 * force])      # a contact arrow starts at its point
        np.testing.assert_allclose(snap.overlays["targets"]["points"], [[0.4, 0.1, 0.5]])
        t_end = time.monotonic() + 60
        while live.stats()["frames_drawn"] < 1 and time.monotonic() < t_end:
            time.sleep(0.1)
        assert live.stats()["frames_drawn"] >= 1
        plate = live.spec["environment"][0]         # plain values (wbc.viz.live.surface_spec)
        assert plate["kind"] == "box"
        assert plate["center"][2] + 0.5 * plate["size"][2] == pytest.approx(0.3)     # its top face at its point
    finally:
        view.finish("unused.html")
    assert view.view.process.poll() is not None          # the drawing process ended
