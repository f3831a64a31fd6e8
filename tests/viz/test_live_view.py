"""The live view (viser) in headless Chromium, driven over the DevTools protocol: a person's
actions on the page reach the controller.

One served run of ``talos_reach`` (paused after its first cycle, so the page and the test
see a still robot) and one Chromium on its page, for every test of this module:

- dragging the right hand's gizmo with the mouse (a press on its x arrow, where the camera
  puts it, a move along it, a release) moves the right-hand task's target in the controller's stack along +x, and then,
  once the run steps on, the hand itself (the simulator's state) towards it;
- the CoM task's kp slider, moved with the keyboard (End: its top), sets the task's gain to
  the top of its range (:func:`wbc.tasks.tuning.gain_range`);
- the Pause button stops simulated time (the snapshots' ``t`` stays put for a second of wall
  time) and the same button resumes it;
- a second tab opened after the run moved on gets the current scene: the robot drawn, the
  status line at the current simulated time;
- two tabs moving the same kp slider, one right after the other (one to zero, one to its top,
  neither waiting for the page): both commands reach the loop and the gain is the last one's,
  inside the slider's range; closing one tab mid-run
  leaves the run going and the drawing on;
- (its own run) a browser killed mid-run: the run finishes its duration, its metrics complete.

Skipped with a reason when Chromium (Debian package ``chromium``) or viser is absent.
"""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from .test_browser import CHROMIUM, DevTools, _kill, launch_devtools

pytestmark = pytest.mark.browser
CAMERA_FOV = 75.0           # degrees: the viewer's default vertical field of view
ROOT = Path(__file__).resolve().parents[2]
INPUT_TIMEOUT = 120.0       # s: an input event's acknowledgement, an animation frame (a loaded machine)

# a child text node equal to NAME: the element showing it (a folder's title, a button's label)
FIND = """function wbcFind(name) {
  var all = document.querySelectorAll('*');
  for (var i = 0; i < all.length; i++) {
    var nodes = all[i].childNodes;
    for (var j = 0; j < nodes.length; j++) {
      if (nodes[j].nodeType === 3 && nodes[j].textContent.trim() === name) { return all[i]; }
    }
  }
  return null;
}"""


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """(view, stack, chromium DevTools port, screenshot folder): a live talos_reach run paused
    after one cycle, its page open in Chromium (a 1000×700 window, the camera 1 m to the
    left of the right hand, looking at it: the world's x axis points left on the screen)."""
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    pytest.importorskip("viser", reason="the live view needs viser (a runtime dependency of wbc)")
    from wbc.cli.live import run_with_view
    from wbc.runner.options import RunOptions
    from wbc.scenario.loader import load_config

    root = tmp_path_factory.mktemp("live")
    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_reach.yaml")
    views: list = []
    result: dict = {}

    def ready(view):
        view.mailbox.post("pause", True)
        view.mailbox.post("step", 1)        # one cycle: the hands' targets exist, then still
        views.append(view)

    def serve():
        try:
            result["metrics"] = run_with_view(sc, RunOptions(duration=60.0), port=8190, on_ready=ready)
        except BaseException as exc:        # shown by the test that waits on it
            result["error"] = exc
            views.append(None)

    runner = threading.Thread(target=serve, daemon=True)
    runner.start()
    t_end = time.monotonic() + 120
    while not views and time.monotonic() < t_end:
        time.sleep(0.1)
    view = views[0] if views else None
    assert view is not None, f"the live view did not start: {result.get('error')!r}"
    while (view.latest() is None or "right_hand" not in view.latest().targets) and time.monotonic() < t_end:
        time.sleep(0.1)
    target = view.latest().targets["right_hand"][:3, 3].copy()
    camera = target + np.array([0.0, 1.0, 0.0])       # world x points left on the screen
    fmt = ",".join
    url = (view.url + f"?initialCameraPosition={fmt(f'{x:.4f}' for x in camera)}"
           f"&initialCameraLookAt={fmt(f'{x:.4f}' for x in target)}&initialCameraUp=0,0,1")
    proc, port = launch_devtools(CHROMIUM, url, root)
    try:
        t_end = time.monotonic() + 240     # a page counts once it has drawn the scene (software WebGL)
        while not view.clients() and time.monotonic() < t_end:
            time.sleep(0.1)
        assert view.clients(), "the page never connected to the view's server and drew the scene"
        yield view, sc.stack, port, root, url
    finally:
        _kill(proc)
        view.mailbox.post("stop", True)
        runner.join(timeout=60)


def _send(dt: DevTools, method: str, **params) -> None:
    """A DevTools command whose answer nobody waits for (DevTools.call skips it when reading)."""
    import json

    dt.id += 1
    dt.conn.write_message(json.dumps({"id": dt.id, "method": method, "params": params}))


async def _frames(dt: DevTools, n: int) -> None:
    """Return once the page has begun ``n`` animation frames after this call (``requestAnimationFrame``:
    the page's rendering and its pointer handling run in these)."""
    await dt.call("Runtime.evaluate", reply_timeout=INPUT_TIMEOUT, awaitPromise=True, returnByValue=True,
                  expression=f"new Promise(function (done) {{ var k = 0; function f() {{ if (++k >= {n}) "
                             "{ done(k); } else { requestAnimationFrame(f); } } requestAnimationFrame(f); })")


def _run(coro, timeout: float = 150.0):
    return asyncio.run(asyncio.wait_for(coro, timeout))


async def _click(dt: DevTools, name: str, timeout: float = 30.0) -> bool:
    """Click the element labelled ``name`` once the page shows it (False: it never did)."""
    t_end = time.monotonic() + timeout
    while True:
        if await dt.evaluate(f"(function () {{ {FIND} var e = wbcFind({name!r}); "
                             "if (!e) { return false; } e.click(); return true; })()"):
            return True
        if time.monotonic() > t_end:
            return False
        await asyncio.sleep(0.5)


def _wait(cond, timeout: float) -> bool:
    t_end = time.monotonic() + timeout
    while not cond() and time.monotonic() < t_end:
        time.sleep(0.05)
    return cond()


def _hand(view, snap) -> np.ndarray:
    """The right hand's position (m) in the simulator's state of a snapshot."""
    robot = view.robot
    data = robot.model.createData()
    fid = robot.frame_id("right_hand")
    pin.framesForwardKinematics(robot.model, data, snap.q)
    return data.oMf[fid].translation.copy()


def test_dragging_the_hand_gizmo_moves_the_target_then_the_hand(served):
    from wbc.viz.controls import GIZMO_SCALE

    view, stack, port, root, _ = served
    start_target = stack["right_hand"].target.translation.copy()
    start_hand = _hand(view, view.latest())

    async def drag():
        dt = await DevTools.attach(port)
        # not the left hand's gizmo, between the camera and the right hand's; the drawing process
        # has applied it, then the page has drawn frames since (no fixed delay: a loaded machine's
        # software renderer may take seconds per frame)
        sent = view.send("gizmos", ["right_hand"])
        assert _wait(lambda: view.handled() >= sent, 60), "the drawing process did not apply the gizmos message"
        await asyncio.sleep(0.5)                            # its websocket message on the way to the page
        await _frames(dt, 3)
        w, h = await dt.evaluate("[window.innerWidth, window.innerHeight]")
        # the gizmo sits at the view's centre (the camera looks at the target from 1 m); its x
        # arrow, GIZMO_SCALE m long, points left: grab it three quarters along
        px_per_m = (h / 2) / np.tan(np.deg2rad(CAMERA_FOV) / 2)
        x0, y0 = w / 2 - 0.75 * GIZMO_SCALE * px_per_m, h / 2
        # the pointer first rests on the arrow (the gizmo picks its axis on hover, at the page's next
        # frame), then presses and moves: each event acknowledged (headless Chromium acknowledges an
        # input event once it has been dispatched, which a loaded machine may take long to do), then
        # frames drawn after it, whatever time that takes
        events = [("mouseMoved", x0 + 2, 0), ("mouseMoved", x0, 0), ("mousePressed", x0, 1)]
        events += [("mouseMoved", x0 - 6 * i, 1) for i in range(1, 13)] + [("mouseReleased", x0 - 72, 0)]
        for kind, x, buttons in events:
            await dt.call("Input.dispatchMouseEvent", reply_timeout=INPUT_TIMEOUT, type=kind, x=x, y=y0,
                          button="left", buttons=buttons,
                          clickCount=1 if kind in ("mousePressed", "mouseReleased") else 0)
            await _frames(dt, 3 if kind == "mouseMoved" and buttons == 0 else 1)
        t_end = time.monotonic() + 60
        while ("target", "right_hand") not in view.from_page and time.monotonic() < t_end:
            await asyncio.sleep(0.2)
        await _frames(dt, 2)                                # the rest of the drag
        await dt.screenshot(root / "dragged.png")
        view.send("gizmos", None)
        dt.conn.close()
        return None, (x0, y0)

    _, grabbed = _run(drag(), 600.0)
    assert ("target", "right_hand") in view.from_page, \
        f"the drag at {grabbed} reached no gizmo; the page sent {list(view.page_log)}"
    view.mailbox.post("step", 2)         # the posted target applies at the start of the next cycle
    assert _wait(lambda: not np.allclose(stack["right_hand"].target.translation, start_target), 30)
    moved = stack["right_hand"].target.translation - start_target
    print(f"gizmo grabbed at {grabbed}: the target moved {moved * 1e3} mm")
    assert moved[0] > 0.03 and abs(moved[1]) < 0.01 + 0.2 * moved[0] and abs(moved[2]) < 0.01 + 0.2 * moved[0]
    new_target = stack["right_hand"].target.translation.copy()
    t0 = view.latest().t
    view.mailbox.post("step", 600)       # 0.6 s of simulated time
    assert _wait(lambda: view.latest().t >= t0 + 0.59, 120), "the run did not step on"
    hand = _hand(view, view.latest())
    print(f"hand moved {(hand - start_hand) * 1e3} mm towards the target; left "
          f"{np.linalg.norm(new_target - hand) * 1e3:.1f} mm of {np.linalg.norm(new_target - start_hand) * 1e3:.1f}")
    assert hand[0] - start_hand[0] > 0.5 * moved[0]
    assert np.linalg.norm(new_target - hand) < 0.5 * np.linalg.norm(new_target - start_hand)


def test_the_kp_slider_sets_the_task_gain_within_its_range(served):
    from wbc.tasks.tuning import gain_range

    view, stack, port, root, _ = served
    com = stack["com"]
    top = gain_range(com, float(com.kp))[1]
    assert com.kp != top

    async def slide():
        dt = await DevTools.attach(port)
        assert await _click(dt, "com"), "no 'com' folder on the page"
        await asyncio.sleep(1.0)
        focused = await dt.evaluate(f"""(function () {{ {FIND}
            var e = wbcFind('com');
            while (e && !e.querySelector('[role=slider]')) {{ e = e.parentElement; }}
            if (!e) {{ return null; }}
            var s = e.querySelector('[role=slider]'); s.focus();
            return [s.getAttribute('aria-valuenow'), s.getAttribute('aria-valuemax'),
                    document.activeElement === s]; }})()""")
        assert focused and focused[2], f"the com folder's kp slider was not focused: {focused}"
        for kind in ("keyDown", "keyUp"):
            await dt.call("Input.dispatchKeyEvent", type=kind, key="End", code="End", windowsVirtualKeyCode=35)
        await asyncio.sleep(1.0)
        dt.conn.close()
        return focused

    before = _run(slide())
    view.mailbox.post("step", 1)
    assert _wait(lambda: float(com.kp) == top, 30), f"kp {com.kp}, expected the slider's top {top} (was {before})"
    assert np.isclose(float(np.max(com.kd)), 2.0 * np.sqrt(top))        # still critically damped


def test_pause_stops_simulated_time(served):
    view, stack, port, root, _ = served

    async def toggle(label: str):
        dt = await DevTools.attach(port)
        ok = await _click(dt, label)
        dt.conn.close()
        return ok

    if view.latest().paused:        # paused by the fixture
        view.mailbox.post("pause", False)
    assert _wait(lambda: not view.latest().paused, 30)
    t_run = view.latest().t
    assert _wait(lambda: view.latest().t > t_run + 0.05, 60), "the run does not advance"
    assert _run(toggle("Pause")), "no Pause button"
    assert _wait(lambda: view.latest().paused, 30)
    t1 = view.latest().t
    time.sleep(1.0)
    t2 = view.latest().t
    assert t2 == t1, f"simulated time moved from {t1} to {t2} while paused"
    assert _run(toggle("Resume")), "the button does not say Resume"
    assert _wait(lambda: view.latest().t > t2 + 0.05, 60), "the run did not resume"


# ------------------------------------------------------------------ more than one tab
def _tabs(port: int) -> list[dict]:
    import http.client
    import json

    c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    c.request("GET", "/json/list")
    pages = [t for t in json.loads(c.getresponse().read()) if t["type"] == "page"]
    c.close()
    return pages


def _new_tab(port: int, url: str) -> dict:
    """A new tab on ``url`` (DevTools' HTTP endpoint): its target (id, webSocketDebuggerUrl)."""
    import http.client
    import json

    c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    c.request("PUT", "/json/new?" + url)
    tab = json.loads(c.getresponse().read())
    c.close()
    return tab


def _close_tab(port: int, tab: dict) -> None:
    import http.client

    c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    c.request("GET", f"/json/close/{tab['id']}")
    c.getresponse().read()
    c.close()
    t_end = time.monotonic() + 20        # gone from the list (else the next test may pick it)
    while any(t["id"] == tab["id"] for t in _tabs(port)) and time.monotonic() < t_end:
        time.sleep(0.2)


async def _attach(tab: dict) -> DevTools:
    from tornado.websocket import websocket_connect

    return DevTools(await websocket_connect(tab["webSocketDebuggerUrl"], max_message_size=256 << 20))


def _scene_share(a: np.ndarray, b: np.ndarray) -> float:
    """The share of the 3D view's pixels (the left half: the control panel is on the right, its
    folders open or closed per tab) that differ."""
    w = a.shape[1] // 2
    return float(np.mean(np.linalg.norm(a[:, :w] - b[:, :w], axis=2) > 30.0))


async def _viewport(dt: DevTools) -> None:
    """One viewport size for every tab (a new tab's window differs from the first's)."""
    await dt.call("Emulation.setDeviceMetricsOverride", width=800, height=480, deviceScaleFactor=1, mobile=False)


def _pause(view) -> None:
    view.mailbox.post("pause", True)
    assert _wait(lambda: view.latest().paused, 30)


def _dark_share(img: np.ndarray) -> float:
    """The share of the 3D view's pixels that are dark (the robot's black and dark grey parts; the
    empty scene's floor and sky are light)."""
    w = img.shape[1] // 2
    return float(np.mean(np.all(img[:, :w] < 90.0, axis=2)))


STATUS = f"""(function () {{ {FIND} var all = document.querySelectorAll('p, div, span');
  for (var i = 0; i < all.length; i++) {{ var s = all[i].textContent;
    if (s.indexOf('t = ') === 0 && s.indexOf('paused') > 0 && all[i].children.length === 0) {{ return s; }} }}
  return null; }})()"""


def test_a_second_tab_gets_the_current_scene(served):
    """A tab opened after the run moved on: the robot drawn, the run's status as it is now (the
    camera of each tab is its own: the 3D views are not compared pixel by pixel)."""
    view, stack, port, root, url = served
    _pause(view)
    target = stack["right_hand"].target.translation + np.array([0.0, 0.0, 0.15])
    t0 = view.latest().t
    view.mailbox.post(("target", "right_hand"), target)       # the hand 15 cm up, 0.5 s of motion
    view.mailbox.post("step", 500)
    assert _wait(lambda: view.latest().t >= t0 + 0.5 - 5e-4, 120)      # all 500 steps taken (dt = 1 ms)
    now = f"t = {view.latest().t:.3f} s"

    async def second_tab():
        tab = _new_tab(port, url)
        try:
            dt = await _attach(tab)
            t_end = time.monotonic() + 60
            while view.clients() < 2 and time.monotonic() < t_end:
                await asyncio.sleep(0.2)
            clients = view.clients()
            t_end = time.monotonic() + 60       # the meshes received, parsed and drawn (slow under load)
            while True:
                await asyncio.sleep(3.0)
                shot = await dt.screenshot(root / "tab2.png")
                status = await dt.evaluate(STATUS)
                if (_dark_share(shot) > 0.05 and status and status.startswith(now)) or time.monotonic() > t_end:
                    break
            dt.conn.close()
        finally:
            _close_tab(port, tab)
        return shot, status, clients

    shot, status, clients = _run(second_tab())
    print(f"second tab: status {status!r} (the run: {now}), {_dark_share(shot):.0%} of its 3D view dark (the "
          f"robot); screenshot in {root}")
    assert clients == 2
    assert status is not None and status.startswith(now), (status, now)
    assert _dark_share(shot) > 0.05


async def _focus_kp(dt: DevTools) -> bool:
    """Focus the com task's kp slider, opening its folder if closed (the folder: the nearest
    ancestor of its title holding a slider, not the Run folder's speed slider)."""
    expr = f"""(function () {{ {FIND}
        var e = wbcFind('com');
        while (e && !e.querySelector('[role=slider]')) {{ e = e.parentElement; }}
        if (!e || e.textContent.indexOf('speed (') >= 0) {{ return false; }}
        var s = e.querySelector('[role=slider]'); s.focus(); return document.activeElement === s; }})()"""
    await dt.call("Page.bringToFront")           # focus goes to the tab in front only
    t_end = time.monotonic() + 60
    while time.monotonic() < t_end:
        if await dt.evaluate(expr):
            return True
        await _click(dt, "com")
        await asyncio.sleep(2.0)
    return False


def test_two_tabs_sending_at_once_the_last_command_wins(served):
    view, stack, port, root, url = served
    com = stack["com"]
    top = next(t["kp_range"][1] for t in view.spec["tasks"] if t["name"] == "com")     # the page's slider top
    first = next(t for t in _tabs(port) if t["url"].startswith(view.url))
    tab = _new_tab(port, url)
    seen = len(view.page_log)

    async def both():
        dt1, dt2 = await _attach(first), await _attach(tab)
        t_end = time.monotonic() + 60
        while view.clients() < 2 and time.monotonic() < t_end:
            await asyncio.sleep(0.2)
        await asyncio.sleep(3.0)
        # each tab in front, keyed, not awaited: the first to zero (a step down first, in case it is
        # there already: an unchanged slider sends nothing), the second to the top
        for dt, keys in ((dt1, (("ArrowLeft", 37), ("Home", 36))), (dt2, (("End", 35),))):
            assert await _focus_kp(dt), "no com kp slider to focus"
            for key, code in keys:
                for kind in ("keyDown", "keyUp"):
                    _send(dt, "Input.dispatchKeyEvent", type=kind, key=key, code=key, windowsVirtualKeyCode=code)
        await asyncio.sleep(3.0)
        dt1.conn.close()
        dt2.conn.close()

    try:
        _run(both())
        view.mailbox.post("step", 1)
        sent = [v for k, v in list(view.page_log)[seen:] if k == ("kp", "com")]
        assert _wait(lambda: float(com.kp) == float(np.clip(sent[-1], 0.0, top)) if sent else False, 30)
        sent = [v for k, v in list(view.page_log)[seen:] if k == ("kp", "com")]
        print(f"kp commands from the two tabs, in arrival order: {sent}; the gain: {com.kp}")
        assert {0.0, top} <= set(sent), f"both tabs' commands did not arrive: {sent}"
        assert float(com.kp) == float(np.clip(sent[-1], 0.0, top))
        # one tab closes while the run goes on: the run and the drawing go on
        view.mailbox.post("pause", False)
        assert _wait(lambda: not view.latest().paused, 30)
    finally:
        _close_tab(port, tab)
    assert _wait(lambda: view.clients() == 1, 30)
    t0, frames = view.latest().t, view.stats()["frames_drawn"]
    assert _wait(lambda: view.latest().t > t0 + 0.1 and view.stats()["frames_drawn"] > frames + 3, 60)


@pytest.mark.slow      # ~1-2 min; test_tab_closed.py covers a tab leaving mid-run by default
def test_a_browser_killed_mid_run_leaves_the_run_and_its_metrics(tmp_path):
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    pytest.importorskip("viser", reason="the live view needs viser")
    from wbc.cli.live import run_with_view
    from wbc.runner.options import RunOptions
    from wbc.scenario.loader import load_config

    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_reach.yaml")
    views: list = []
    result: dict = {}

    def serve():
        try:
            result["metrics"] = run_with_view(sc, RunOptions(duration=1.0), port=8230, wait=True, on_ready=views.append)
        except BaseException as exc:
            result["error"] = exc

    runner = threading.Thread(target=serve, daemon=True)
    runner.start()
    assert _wait(lambda: bool(views) or "error" in result, 120), "the live view did not start"
    view = views[0]
    proc, _ = launch_devtools(CHROMIUM, view.url, tmp_path)
    try:
        assert _wait(lambda: view.latest() is not None and view.latest().t > 0.2, 120), "the run did not start"
    finally:
        _kill(proc)                             # mid-run, without closing its websocket
    runner.join(timeout=300)
    assert not runner.is_alive() and "error" not in result, result.get("error")
    m = result["metrics"]
    print(f"killed at t = 0.2 s: the run ran {m['duration']} s, {m['live_view']['frames_drawn']} frames drawn")
    assert m["duration"] == pytest.approx(1.0, abs=sc.dt / 2)
    assert m["solver_failures"] == 0 and not m["fell"]
    assert {"com", "right_hand"} <= set(m["tasks"])
    assert all(np.isfinite(e["rms"]) for e in m["tasks"].values() if "rms" in e)
    assert m["live_view"]["frames_drawn"] > 0
