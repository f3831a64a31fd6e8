"""The browser view really draws the robot, in headless Chromium:

(a) a recorded HTML replay (``--record``): screenshots at two animation times
    (Chromium's --virtual-time-budget advances the page's clock);
(b) the LIVE Meshcat server page while a run is being served: Chromium is driven
    over the DevTools protocol (``--remote-debugging-port``; a websocket client from
    tornado, which meshcat's server already needs), so each screenshot is taken
    once the scene has arrived over meshcat's websocket, at chosen wall times.

Each test compares the canvas with the empty scene's background: the robot covers
a substantial share of pixels, and the share that changes between two times shows
it moves. Screenshots are kept under pytest's tmp dir (printed with -s).

Marked ``browser``; skipped with a reason when Chromium (Debian package
``chromium``) is absent. Every Chromium runs in its own process group, killed
after its screenshots; every Meshcat server is closed."""

from __future__ import annotations

import asyncio
import base64
import http.client
import json
import os
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
         "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--window-size=800,600"]


def _kill(proc: subprocess.Popen) -> None:
    """No Chromium helper process may outlive its test."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


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
        finally:
            _kill(proc)
        if out.is_file():
            return np.asarray(Image.open(out).convert("RGB"), dtype=float)
    pytest.fail(f"chromium wrote no screenshot of {url}")


def differing_share(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean(np.linalg.norm(a - b, axis=2) > 30.0))


@pytest.fixture(scope="module")
def chromium():
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    return CHROMIUM


# ------------------------------------------------------------ (a) recorded replay
@pytest.fixture(scope="module")
def recordings(chromium, tmp_path_factory):
    from wbc.runner import run
    from wbc.scenario import load_config
    from wbc.viz import Scene, viewer_callback

    d = tmp_path_factory.mktemp("browser")
    sc = load_config(ROOT / "tasks" / "talos_reach.yaml")
    scene = Scene(sc.robot, sc.environment, record=True)
    try:
        run(sc, duration=2.0, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False))
        robot_html = scene.save_html(d / "reach.html")
    finally:
        scene.close()
    empty = Scene(sc.robot, sc.environment, record=True)
    try:
        q = sc.robot.q_default.copy()
        q[2] = 200.0                                   # the robot far above the camera: an empty scene
        empty.show(q)
        empty_html = empty.save_html(d / "empty.html")
    finally:
        empty.close()
    return d, robot_html, empty_html


def test_recorded_replay_draws_the_robot_and_moves(recordings):
    d, robot_html, empty_html = recordings
    assert "wbc-diagnostics" in robot_html.read_text()      # the diagnostics panel rides along
    background = screenshot(empty_html.as_uri(), d / "empty.png", 3000)
    early = screenshot(robot_html.as_uri() + "#no-diagnostics", d / "early.png", 300)
    late = screenshot(robot_html.as_uri() + "#no-diagnostics", d / "late.png", 6000)
    panel = screenshot(robot_html.as_uri(), d / "late_diagnostics.png", 6000)
    drawn = differing_share(early, background)
    moved = differing_share(early, late)
    h, w = panel.shape[:2]
    corner = (slice(0, int(0.15 * h)), slice(0, int(0.5 * w)))
    panel_share = differing_share(panel[corner], late[corner])
    print(f"replay: robot pixels {drawn:.1%}, changed between two animation times {moved:.2%}, diagnostics "
          f"panel {panel_share:.0%} of the top-left corner; screenshots in {d}")
    assert drawn > 0.02
    assert moved > 0.002
    assert panel_share > 0.3


# ------------------------------------------------------------ (b) live server page
class DevTools:
    """A minimal Chrome DevTools protocol client (one page target) on tornado's websocket."""

    def __init__(self, conn) -> None:
        self.conn, self.id = conn, 0

    @classmethod
    async def attach(cls, port: int) -> DevTools:
        from tornado.websocket import websocket_connect

        c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        c.request("GET", "/json/list")
        pages = [t for t in json.loads(c.getresponse().read()) if t["type"] == "page"]
        c.close()
        conn = await websocket_connect(pages[0]["webSocketDebuggerUrl"], max_message_size=256 << 20)
        return cls(conn)

    async def call(self, method: str, **params):
        self.id += 1
        self.conn.write_message(json.dumps({"id": self.id, "method": method, "params": params}))
        while True:
            msg = await asyncio.wait_for(self.conn.read_message(), 30)
            if msg is None:
                raise ConnectionError("DevTools connection closed")
            msg = json.loads(msg)
            if msg.get("id") == self.id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]

    async def evaluate(self, expr: str):
        return (await self.call("Runtime.evaluate", expression=expr, returnByValue=True))["result"].get("value")

    async def screenshot(self, out: Path) -> np.ndarray:
        import io

        from PIL import Image

        data = base64.b64decode((await self.call("Page.captureScreenshot", format="png"))["data"])
        out.write_bytes(data)
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), dtype=float)


# number of robot meshes the page has received over meshcat's websocket (-1: none yet)
ROBOT_NODES = """(function () {
  try { return Object.keys(viewer.scene_tree.children["meshcat"].children["robot"]
                          .children["visuals"].children).length; } catch (e) { return -1; } })()"""
HUD_NODES = """(function () {
  try { var c = viewer.scene_tree.children["Cameras"].children["default"].children["rotated"]
                    .children["<object>"].children["wbc_diagnostics"];
        return c.children["<object>"].object.material.map ? 1 : 0; } catch (e) { return 0; } })()"""


async def _wait_for(dt: DevTools, expr: str, minimum: int, timeout: float) -> int:
    t_end = time.monotonic() + timeout
    value = await dt.evaluate(expr)
    while (value is None or value < minimum) and time.monotonic() < t_end:
        await asyncio.sleep(0.2)
        value = await dt.evaluate(expr)
    return value


def test_live_server_page_draws_the_robot_while_a_run_is_served(chromium, tmp_path):
    from wbc.runner import run
    from wbc.scenario import load_config
    from wbc.viz import Scene, viewer_callback

    sc = load_config(ROOT / "tasks" / "talos_reach.yaml")
    n_meshes = None
    scene = Scene(sc.robot, sc.environment)
    proc = None
    runner = None
    try:
        assert scene.url.startswith("http://127.0.0.1:")
        n_meshes = len(scene.geom.geometryObjects)
        q = sc.robot.q_default.copy()
        q[2] = 200.0                              # first the empty scene: the robot far above the camera
        scene.show(q)
        for attempt in range(2):      # headless Chromium occasionally hangs at start-up: once more
            profile = tmp_path / f"profile{attempt}"
            proc = subprocess.Popen([chromium, *FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0",
                                     "--remote-allow-origins=*", scene.url],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
            port_file = profile / "DevToolsActivePort"
            t_end = time.monotonic() + 20
            while not (port_file.is_file() and port_file.read_text().strip()) and time.monotonic() < t_end:
                time.sleep(0.1)
            if port_file.is_file():
                break
            _kill(proc)
            proc = None
        assert proc is not None, "Chromium did not open its DevTools port (twice 20 s)"
        port = int(port_file.read_text().split()[0])
        done = threading.Event()

        def serve():          # the run, played at real time into the live page
            try:
                run(sc, duration=2.5, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=True))
            finally:
                done.set()

        async def drive():
            dt = await DevTools.attach(port)
            got = await _wait_for(dt, ROBOT_NODES, n_meshes, 30)
            assert got >= n_meshes, f"the page received {got} of {n_meshes} robot meshes"
            await asyncio.sleep(1.0)                           # meshes parsed and drawn
            background = await dt.screenshot(tmp_path / "live_empty.png")
            runner_thread = threading.Thread(target=serve, daemon=True)
            runner_thread.start()
            hud = await _wait_for(dt, HUD_NODES, 1, 20)
            await asyncio.sleep(0.8)
            first = await dt.screenshot(tmp_path / "live_1.png")
            await asyncio.sleep(1.2)
            second = await dt.screenshot(tmp_path / "live_2.png")
            dt.conn.close()
            return background, first, second, hud, runner_thread

        background, first, second, hud, runner = asyncio.run(asyncio.wait_for(drive(), 55))
        hud_box = scene.hud_box
    finally:
        if proc is not None:
            _kill(proc)
        if runner is not None:
            runner.join(timeout=30)
        scene.close()
    h, w = first.shape[:2]
    # the diagnostics panel's pixels (its box in camera units at depth 1: view height 2 tan(fov/2))
    from wbc.viz.scene import HUD_FOV

    x0, y0, bw, bh = hud_box
    px = (h / 2) / np.tan(HUD_FOV / 2)
    c0, c1 = int(w / 2 + x0 * px) - 4, int(w / 2 + (x0 + bw) * px) + 4
    r0, r1 = max(int(h / 2 - y0 * px) - 4, 0), int(h / 2 - (y0 - bh) * px) + 4
    outside = np.ones((h, w), bool)
    outside[r0:r1, max(c0, 0):c1] = False

    def share(a, b, mask):
        return float(np.mean((np.linalg.norm(a - b, axis=2) > 30.0)[mask]))

    drawn = share(first, background, outside)
    moved = share(first, second, outside)
    panel = share(first, background, ~outside)
    print(f"live page ({w}×{h}): robot pixels {drawn:.1%}, changed between two times {moved:.2%}; diagnostics "
          f"panel rows {r0}-{r1}, columns {c0}-{c1}: {panel:.0%} of its pixels drawn; screenshots in {tmp_path}")
    assert hud == 1, "the diagnostics panel never reached the page"
    assert drawn > 0.02
    assert moved > 0.002
    assert panel > 0.3
