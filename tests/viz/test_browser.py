"""The browser view really draws the robot, in headless Chromium:

(a) a recorded HTML replay (``--record``): screenshots at two animation times, the
    page driven over the DevTools protocol (as in (c));
(b) the LIVE Meshcat server page while a run is being served: Chromium is driven
    over the DevTools protocol (``--remote-debugging-port``; a websocket client from
    tornado, which meshcat's server already needs), so each screenshot is taken
    once the scene has arrived over meshcat's websocket, at chosen wall times;
(c) a recorded push: the replay page driven over the DevTools protocol, its
    animation paused and set to chosen times (``viewer.animator.seek``), so that the
    push arrow shows while the push acts and only then, and the contact-force arrows
    have their length (meshcat's animations keep position and quaternion only: the
    scene records scale and visibility as tracks of their own).

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

ROOT = Path(__file__).resolve().parents[2]
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
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.viz import Scene, viewer_callback

    d = tmp_path_factory.mktemp("browser")
    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_reach.yaml")
    scene = Scene(sc.robot, sc.environment, record=True)
    try:
        run(sc, duration=2.0, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False))
        robot_html = scene.save_html(d / "reach.html")
    finally:
        scene.close()
    return d, robot_html, empty_replay(sc, d / "empty.html")


def empty_replay(sc, path: Path) -> Path:
    """A replay of ``sc``'s scene with the robot far above the camera: the background."""
    from wbc.viz import Scene

    empty = Scene(sc.robot, sc.environment, record=True)
    try:
        q = sc.robot.q_default.copy()
        q[2] = 200.0                                   # the robot far above the camera: an empty scene
        empty.show(q)
        return empty.save_html(path)
    finally:
        empty.close()


def test_recorded_replay_draws_the_robot_and_moves(chromium, recordings):
    d, robot_html, empty_html = recordings
    assert "wbc-diagnostics" in robot_html.read_text()      # the diagnostics panel rides along
    background = replay_screenshots(chromium, empty_html.as_uri(), d / "empty", [0.0])[0.0]
    shots = replay_screenshots(chromium, robot_html.as_uri() + "#no-diagnostics", d / "reach", [0.1, 1.9])
    early, late = shots[0.1], shots[1.9]
    panel = replay_screenshots(chromium, robot_html.as_uri(), d / "reach_diagnostics", [1.9])[1.9]
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
def launch_devtools(chromium: str, url: str, root: Path) -> tuple[subprocess.Popen, int]:
    """Chromium on ``url`` with a DevTools port (profiles under ``root``): (process, port).
    The caller kills the process (:func:`_kill`)."""
    for attempt in range(2):      # headless Chromium occasionally hangs at start-up: once more
        profile = root / f"profile{attempt}"
        proc = subprocess.Popen([chromium, *FLAGS, f"--user-data-dir={profile}", "--remote-debugging-port=0",
                                 "--remote-allow-origins=*", url],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        port_file = profile / "DevToolsActivePort"
        t_end = time.monotonic() + 20
        while not (port_file.is_file() and port_file.read_text().strip()) and time.monotonic() < t_end:
            time.sleep(0.1)
        if port_file.is_file() and port_file.read_text().strip():
            return proc, int(port_file.read_text().split()[0])
        _kill(proc)
    pytest.fail("Chromium did not open its DevTools port (twice 20 s)")


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

    async def call(self, method: str, reply_timeout: float = 30.0, **params):
        self.id += 1
        self.conn.write_message(json.dumps({"id": self.id, "method": method, "params": params}))
        while True:
            msg = await asyncio.wait_for(self.conn.read_message(), reply_timeout)
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

# the replay's animation loaded and played to its end (the player then rewinds, paused)
ANIMATION_DONE = """(function () {
  try { var a = viewer.animator; return (a.actions.length > 0 && !a.playing) ? a.actions.length : -1; }
  catch (e) { return -1; } })()"""


async def _wait_for(dt: DevTools, expr: str, minimum: int, timeout: float) -> int:
    t_end = time.monotonic() + timeout
    value = await dt.evaluate(expr)
    while (value is None or value < minimum) and time.monotonic() < t_end:
        await asyncio.sleep(0.2)
        value = await dt.evaluate(expr)
    return value


def replay_screenshots(chromium: str, url: str, root: Path, times: list[float]) -> dict[float, np.ndarray]:
    """Screenshots of a recorded replay page (``root`` holds them and the profiles) at the
    animation times ``times`` (s): the page's animation played once to its end, then paused
    and set to each time over the DevTools protocol. (Chromium's --screenshot with a
    --virtual-time-budget hung now and then on these WebGL pages, 3 attempts in a row once
    in CI, where DevTools screenshots of the same pages never did.)"""
    root.mkdir(parents=True, exist_ok=True)
    proc, port = launch_devtools(chromium, url, root)

    async def drive():
        dt = await DevTools.attach(port)
        loaded = await _wait_for(dt, ANIMATION_DONE, 1, 30)
        assert loaded > 0, f"the replay's animation never played: {url}"
        shots = {}
        for t in times:
            await dt.evaluate(f"viewer.animator.pause(); viewer.animator.seek({t}); 0")
            await asyncio.sleep(0.5)                          # drawn by the page's animation loop
            shots[t] = await dt.screenshot(root / f"t{t}.png")
        dt.conn.close()
        return shots

    try:
        return asyncio.run(asyncio.wait_for(drive(), 60))
    finally:
        _kill(proc)


class _Stopped(Exception):
    """Raised in the run's callback to end a served run early."""


def test_live_server_page_draws_the_robot_while_a_run_is_served(chromium, tmp_path):
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.viz import Scene, viewer_callback

    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_reach.yaml")
    n_meshes = None
    scene = Scene(sc.robot, sc.environment)
    proc = None
    stop, started = threading.Event(), []      # the run's stop signal, its thread once started
    try:
        assert scene.url.startswith("http://127.0.0.1:")
        n_meshes = len(scene.geom.geometryObjects)
        q = sc.robot.q_default.copy()
        q[2] = 200.0                              # first the empty scene: the robot far above the camera
        scene.show(q)
        proc, port = launch_devtools(chromium, scene.url, tmp_path)
        done = threading.Event()
        draw = viewer_callback(scene, sc.stack, sc.dt, realtime=True)

        def until_stopped(t, sim, sol):
            if stop.is_set():          # the test is over: end the run before the scene closes
                raise _Stopped
            draw(t, sim, sol)

        def serve():          # the run, played at real time into the live page
            try:
                run(sc, duration=2.5, callback=until_stopped)
            except _Stopped:
                pass
            finally:
                done.set()

        async def drive():
            dt = await DevTools.attach(port)
            got = await _wait_for(dt, ROBOT_NODES, n_meshes, 30)
            assert got >= n_meshes, f"the page received {got} of {n_meshes} robot meshes"
            await asyncio.sleep(1.0)                           # meshes parsed and drawn
            background = await dt.screenshot(tmp_path / "live_empty.png")
            runner_thread = threading.Thread(target=serve, daemon=True)
            started.append(runner_thread)
            runner_thread.start()
            hud = await _wait_for(dt, HUD_NODES, 1, 20)
            await asyncio.sleep(0.8)
            first = await dt.screenshot(tmp_path / "live_1.png")
            await asyncio.sleep(1.2)
            second = await dt.screenshot(tmp_path / "live_2.png")
            dt.conn.close()
            return background, first, second, hud, runner_thread

        background, first, second, hud, _ = asyncio.run(asyncio.wait_for(drive(), 55))
        hud_box = scene.hud_box
    finally:
        # the run is stopped and joined first, while the page is still open: meshcat's bridge
        # answers a drawing command only after forwarding it to the page (a page killed mid-send
        # leaves the run's zmq request waiting forever), and closing the scene's transport while
        # the run still draws aborts the process (zmq)
        stop.set()
        for th in started:
            th.join()
        if proc is not None:
            _kill(proc)
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


# ------------------------------------------------------------ (c) a recorded push, animation times set
# the push arrow's and the contact-force arrows' states in the page: [visible, scale x, y, z]
ARROW_STATES = """(function () {
  function state(o) { return [o.visible, o.scale.x, o.scale.y, o.scale.z]; }
  var m = viewer.scene_tree.children["meshcat"].children, forces = m["forces"].children;
  return [state(m["pushes"].children["0"].object)].concat(
    Object.keys(forces).map(function (k) { return state(forces[k].object); })); })()"""


def purple(img: np.ndarray) -> np.ndarray:
    """Pixels of the push arrow's colour (0x8E44AD, lit): red and blue well above green
    (the sky, the ground, the robot and the orange contact arrows are not)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r - g > 40) & (b - g > 60)


def test_recorded_replay_shows_the_push_arrow_only_while_it_acts(chromium, tmp_path):
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.viz import Scene, viewer_callback

    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_push.yaml")     # 150 N at the torso from t = 1.0 s for 0.1 s
    (push,) = sc.pushes
    assert (push["start"], push["duration"]) == (1.0, 0.1)
    scene = Scene(sc.robot, sc.environment, record=True)
    try:
        run(sc, duration=1.25, callback=viewer_callback(scene, sc.stack, sc.dt, realtime=False, diagnostics_hz=0))
        html = scene.save_html(tmp_path / "push.html")
    finally:
        scene.close()
    tracks = {path.lower(): set(clip.tracks) for path, clip in scene.anim.clips.items()}
    for node in ("/meshcat/pushes/0", "/meshcat/forces/p0"):
        assert {"position", "quaternion", "scale", "visible"} <= tracks[node], (node, tracks[node])

    # frames are drawn every 33 ms of simulated time and played at 30 per second: the push's
    # frames play from 1.033 s to 1.133 s
    times = {"before": 0.95, "during": 1.07, "after": 1.2}
    proc, port = launch_devtools(chromium, html.as_uri(), tmp_path)

    async def drive():
        dt = await DevTools.attach(port)
        loaded = await _wait_for(dt, ANIMATION_DONE, 1, 30)
        assert loaded > 0, "the replay's animation never played"
        # a view from behind on the left, close to the torso (the default camera looks at the
        # robot's front: the arrow, behind the torso, would be hidden); camera coordinates are y-up
        await dt.evaluate('viewer.set_property(["Cameras", "default", "rotated", "<object>"], "position", '
                          '[-0.8, 1.3, 1.2]); viewer.controls.target.set(0.0, 0.9, 0.0); 0')
        shots, states = {}, {}
        for name, t in times.items():
            await dt.evaluate(f"viewer.animator.pause(); viewer.animator.seek({t}); 0")
            await asyncio.sleep(0.5)                          # drawn by the page's animation loop
            states[name] = await dt.evaluate(ARROW_STATES)
            shots[name] = await dt.screenshot(tmp_path / f"push_{name}.png")
        dt.conn.close()
        return shots, states

    try:
        shots, states = asyncio.run(asyncio.wait_for(drive(), 60))
    finally:
        _kill(proc)
    arrow = {name: int(purple(img).sum()) for name, img in shots.items()}
    region = purple(shots["during"])
    rows, cols = np.nonzero(region)
    box = (slice(max(rows.min() - 10, 0), rows.max() + 10), slice(max(cols.min() - 10, 0), cols.max() + 10)) \
        if region.any() else (slice(0, 0), slice(0, 0))
    changed = {name: differing_share(shots["during"][box], shots[name][box]) for name in ("before", "after")}
    push_state = {name: st[0] for name, st in states.items()}
    forces = [f for st in states.values() for f in st[1:] if f[0]]     # the contact-force arrows shown
    lengths = [f[2] for f in forces if f[1] == f[3] == 1.0]
    print(f"push replay: push-arrow pixels {arrow}; in its box (rows {box[0].start}-{box[0].stop}, columns "
          f"{box[1].start}-{box[1].stop}) {changed['before']:.0%} / {changed['after']:.0%} of the pixels differ "
          f"from before / after the push; push arrow [visible, scale] {push_state}; {len(forces)} contact-force "
          f"arrows shown, {min(lengths, default=0):.3f}-{max(lengths, default=0):.3f} m; screenshots in {tmp_path}")
    assert push_state["during"][0] is True and np.allclose(push_state["during"][1:], [1.0, 0.3, 1.0], atol=1e-4)
    for name in ("before", "after"):
        assert push_state[name][0] is False and max(push_state[name][1:]) < 1e-3
    # the loaded foot corners' arrows (1 mm per 2 N: up to some 40 cm), not unit cylinders; an
    # arrow whose corner unloads at the next frame is still visible, shrinking in place (its
    # whole scale interpolated towards the hidden one), which a seek may land on
    shown = [f for f in forces if f[1] == f[3] == 1.0]
    assert len(shown) >= 3 * len(times)
    assert all(0.0 < f[2] < 0.8 for f in shown), shown
    assert all(f[1] == f[3] < 1.0 and f[2] < 0.8 for f in forces if not f[1] == f[3] == 1.0), forces
    assert max(lengths) > 0.05
    assert arrow["during"] > 100
    assert arrow["before"] == arrow["after"] == 0
    assert min(changed.values()) > 0.1
