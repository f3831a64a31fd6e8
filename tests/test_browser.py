"""The browser view really draws the robot: headless Chromium screenshots of a
recorded HTML replay (the live server page is not checked yet: headless Chromium
takes its screenshot before the scene arrives over the websocket).

Marked ``browser``: deselected by default, run with ``pytest -m browser``; skipped
with a reason when Chromium (Debian package ``chromium``) is absent."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.browser

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
         "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--window-size=800,600"]


def screenshot(url: str, out: Path, budget_ms: int) -> np.ndarray:
    from PIL import Image

    for attempt in range(3):
        # headless Chromium occasionally hangs at start-up (zygote): give it 60 s, then retry
        proc = subprocess.Popen([CHROMIUM, *FLAGS, f"--user-data-dir={out.parent / f'profile{attempt}{budget_ms}'}",
                                 f"--virtual-time-budget={budget_ms}", f"--screenshot={out}", url],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            pass
        finally:   # no Chromium helper process may outlive its screenshot
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait()
        if out.is_file():
            return np.asarray(Image.open(out).convert("RGB"), dtype=float)
    pytest.fail(f"chromium wrote no screenshot of {url}")


def differing_share(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean(np.linalg.norm(a - b, axis=2) > 30.0))


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    from wbc.runner import run
    from wbc.scenario import load_config
    from wbc.viz import Scene, viewer_callback

    root = Path(__file__).resolve().parent.parent
    d = tmp_path_factory.mktemp("browser")
    sc = load_config(root / "tasks" / "talos_reach.yaml")
    scene = Scene(sc.robot, sc.environment, record=True)
    run(sc, duration=2.0, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False))
    robot_html = scene.save_html(d / "reach.html")
    scene.close()
    empty = Scene(sc.robot, sc.environment, record=True)
    q = sc.robot.q_default.copy()
    q[2] = 200.0                                   # the robot far above the camera: an empty scene
    empty.show(q)
    empty_html = empty.save_html(d / "empty.html")
    empty.close()
    return d, robot_html, empty_html


def test_recorded_replay_draws_the_robot_and_moves(recordings):
    d, robot_html, empty_html = recordings
    background = screenshot(empty_html.as_uri(), d / "empty.png", 3000)
    early = screenshot(robot_html.as_uri(), d / "early.png", 300)
    late = screenshot(robot_html.as_uri(), d / "late.png", 6000)
    drawn = differing_share(early, background)
    moved = differing_share(early, late)
    print(f"robot pixels {drawn:.1%}, changed between two animation times {moved:.2%}; screenshots in {d}")
    assert drawn > 0.02
    assert moved > 0.002
