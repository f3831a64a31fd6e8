"""A 4 s Talos replay (``wbc run talos_reach --record``) fits in 5 MB and still draws the robot.

The replay holds each robot mesh once (indexed, clustered on a 5 mm grid: wbc.viz.meshes) and
only the animation keys that linear interpolation would not restore (wbc.viz.keyframes); before
both it was 23.4 MB. Its page, opened from the file in headless Chromium (no server, no
internet), shows the robot: a substantial share of the canvas differs from the empty scene's.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from .test_browser import CHROMIUM, differing_share, empty_replay, replay_screenshots

pytestmark = pytest.mark.browser
ROOT = Path(__file__).resolve().parents[2]
LIMIT = 5_000_000       # bytes


def test_a_four_second_talos_replay_stays_under_5_mb_and_draws_the_robot(tmp_path):
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.viz import Scene, viewer_callback

    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_reach.yaml")
    scene = Scene(sc.robot, sc.environment, record=True)
    try:
        run(sc, duration=4.0, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False))
        html = scene.save_html(tmp_path / "reach4.html")
    finally:
        scene.close()
    size = html.stat().st_size
    print(f"4 s talos_reach replay: {size / 1e6:.2f} MB")
    assert size <= LIMIT
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium): size checked, drawing not")
    empty_html = empty_replay(sc, tmp_path / "empty.html")
    background = replay_screenshots(CHROMIUM, empty_html.as_uri(), tmp_path / "empty", [0.0])[0.0]
    shots = replay_screenshots(CHROMIUM, html.as_uri() + "#no-diagnostics", tmp_path / "reach", [0.5, 3.9])
    drawn = differing_share(shots[3.9], background)
    moved = differing_share(shots[0.5], shots[3.9])
    print(f"robot pixels {drawn:.1%}, changed between 0.5 s and 3.9 s {moved:.2%}; screenshots in {tmp_path}")
    assert drawn > 0.02
    assert moved > 0.002
