"""Scene.add_arrow / add_point and show(arrows=..., points=...): in a recording each
arrow keys its length in a ``scale`` track and its presence in a ``visible`` track
(meshcat's animation keeps only position and rotation of a transform)."""

from __future__ import annotations

import numpy as np

import wbc
from wbc.viz import Scene


def test_recorded_extras_keep_length_and_visibility():
    robot = wbc.load_robot("panda")
    scene = Scene(robot, [], record=True)
    try:
        scene.add_arrow("push", 0x8E44AD)
        scene.add_point("goal", 0x2E86DE)
        start, vec = np.array([0.3, 0.0, 0.4]), np.array([0.0, 0.0, 2.0])
        for k in range(4):
            on = k in (1, 2)
            scene.show(robot.q_default, arrows={"push": (start, vec, 0.1) if on else None},
                       points={"goal": [0.1 * k, 0.0, 0.5]})
        clips = {str(p.lower()): c for p, c in scene.anim.clips.items()}
        push = clips["/meshcat/extras/push"].tracks
        assert push["visible"].values == [False, True, True, False]
        assert [s[1] for s in push["scale"].values[1:3]] == [0.1, 0.1]     # length along the cylinder axis
        assert max(push["scale"].values[0]) < 1e-5 and max(push["scale"].values[3]) < 1e-5
        np.testing.assert_allclose(push["position"].values[1], start + 0.05 * vec / 2.0)   # the arrow's middle
        goal = clips["/meshcat/extras/goal"].tracks
        np.testing.assert_allclose([p[0] for p in goal["position"].values], [0.0, 0.1, 0.2, 0.3])
    finally:
        scene.close()
