"""A recording of ``talos_hands_cross`` holds the collision task's witness segments: read from the
saved HTML (its meshcat commands), not from a screenshot. Each of the closest pairs has a fixed
slot (unit segments, one per colour bin: wbc.viz.collisions) whose pose, length and visible bin
the animation keys per frame."""

from __future__ import annotations

import base64
import re
from pathlib import Path

import numpy as np
import umsgpack

from wbc.viz.collisions import BINS, COUNT, color_bin

ROOT = Path(__file__).resolve().parents[2]


def _commands(html: str) -> list[dict]:
    """The meshcat commands a static replay page feeds its viewer."""
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def test_a_talos_hands_cross_recording_holds_the_witness_segments(tmp_path):
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.tasks import CollisionAvoidance
    from wbc.viz import Scene, viewer_callback

    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_hands_cross.yaml")
    (task,) = [t for t in sc.stack if isinstance(t, CollisionAvoidance)]
    scene = Scene(sc.robot, sc.environment, record=True)
    drawn: list[tuple[np.ndarray, np.ndarray, float]] = []     # the first frame's nearest pairs (p1, p2, d)
    try:
        draw = viewer_callback(scene, sc.stack, sc.dt, realtime=False, diagnostics_hz=0)

        def cb(t, sim, sol):
            draw(t, sim, sol)
            if not drawn:
                rows, order = task.last
                drawn.extend((rows.p1[i], rows.p2[i], float(rows.d[i])) for i in order[:COUNT])

        run(sc, duration=0.2, callback=cb)
        html = scene.save_html(tmp_path / "cross.html").read_text()
    finally:
        scene.close()
    assert len(drawn) == COUNT, "talos_hands_cross starts with fewer near pairs than slots"
    cmds = _commands(html)
    base = f"/meshcat/collision/{task.name}"
    lines = {c["path"] for c in cmds if c.get("type") == "set_object" and c["path"].startswith(base)
             and c["object"]["object"]["type"] == "Line"}
    assert lines == {f"{base}/{s}/c{b}" for s in range(COUNT) for b in range(BINS)}
    (anim,) = [c for c in cmds if c.get("type") == "set_animation"]
    clips = {a["path"]: {t["name"]: t["keys"] for t in a["clip"]["tracks"]} for a in anim["animations"]}
    for slot, (p1, p2, d) in enumerate(drawn):
        tracks = clips[f"{base}/{slot}"]
        assert tracks[".visible"][0] == {"time": 0, "value": True}
        np.testing.assert_allclose(tracks[".position"][0]["value"], p1, atol=1e-9)          # starts at p₁
        assert abs(tracks[".scale"][0]["value"][0] - max(np.linalg.norm(p2 - p1), 1e-3)) < 1e-9   # its length
        b = color_bin(d, task.safety, task.influence)
        for j in range(BINS):         # the distance's colour bin alone shown
            assert clips[f"{base}/{slot}/c{j}"][".visible"][0]["value"] == (j == b)
