"""The live browser view (viser), drawn by a process of its own: the control process's side.

:class:`LiveView` starts the drawing process (:mod:`wbc.viz.drawing`: viser's server and event
loop, the scene, the page's controls, plots and diagnostics; ``python -m wbc.viz.drawing``, which
imports nothing of the caller's main module), sends it a plain description of the scene
(:func:`view_spec`) on a socket pair, and keeps, in the control process, only:

- :meth:`LiveView.publish`, which the control loop calls every ``1/fps`` s of simulated time:
  the snapshot's arrays, the run's overlays and, at most ``DIAG_HZ`` times per wall and per
  simulated second, its solution's diagnostics rows are encoded as JSON
  (:mod:`wbc.jsonable`: no pickle) and copied into one shared-memory slot under a
  sequence lock (:mod:`wbc.viz.shared_state`: no lock to wait on, no thread; about 0.1 ms per
  drawn frame, 0.3 ms more with the diagnostics rows); the drawing process takes the latest;
- :meth:`LiveView.drain`, the feed of the mailbox the loop takes its commands from once per
  cycle (:class:`wbc.runner.interactive.Mailbox`, ``feed``): it moves the page's commands that
  arrived on the socket into the mailbox without waiting (one ``poll``, a system call), where the
  last one per key wins.

So the control process's interpreter lock is never held by drawing: the loop's cycle time and
real-time factor are those of a headless run plus the publish (benchmarks/live_view.md).

The page listens on 127.0.0.1 unless ``host`` says otherwise. A second tab gets the current
scene (viser replays its scene state to every new client). The page is viser's own built
client (no internet).
"""

from __future__ import annotations

import os
import select
import socket
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from .. import jsonable
from ..errors import WbcError
from ..options import Options
from ..tasks.tuning import adjustable, gain_range, weight_range
from . import shared_state as ss
from .diagnostics import diagnostics_rows

START_TIMEOUT = 300.0       # s: the drawing process loads the meshes (slow on a loaded machine)
PAGE_LOG = 256              # commands from the page kept in LiveView.page_log (tests, logs)
DIAG_HZ = 5.0               # snapshots per wall second that carry the diagnostics rows
LIVE_MESH_CELL = 0.01       # m: the live page's mesh clustering grid (PageOptions.mesh_cell)


def _check_host(host: str) -> None:
    """Raise :class:`~wbc.errors.WbcError` if this machine cannot listen on ``host``."""
    import socket

    try:
        family = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)[0][0]
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((host, 0))
    except OSError as exc:
        raise WbcError(f"the live view could not listen on {host!r}: {exc}") from None


def task_specs(stack) -> list[dict]:
    """Each task's name, kind, level and slider ranges (:mod:`wbc.tasks.tuning`) as plain values."""
    out = []
    for task in stack:
        kp = float(task.kp) if adjustable(task) else None
        out.append({"name": task.name, "kind": task.kind, "level": stack.level_of(task.name),
                    "rotate": task.moves_orientation,
                    "kp": kp, "kp_range": None if kp is None else gain_range(task, kp),
                    "weight": float(task.weight), "weight_range": weight_range(task)})
    return out


@dataclass(frozen=True)
class PageOptions(Options):
    """How the live page is served and drawn (:class:`LiveView`, :func:`view_spec`)."""

    host: str = "127.0.0.1"
    """where the page listens (127.0.0.1 unless asked)"""
    port: int = 8080
    """its port (the next free one from there)"""
    fps: float = 30.0
    """drawing rate, frames per wall second"""
    speed: float = 1.0
    """the speed slider's initial value, × real time"""
    frames: tuple = ()
    """the robot's frames a push may act on"""
    shown_frames: tuple = ()
    """frames drawn with their axes (a glass)"""
    overlays: dict | None = None
    """the run's overlays {name: shown at start} (:mod:`wbc.viz.overlays`); None: none"""
    force_scale: float = 2.0
    """N per mm of a contact-force arrow"""
    push_scale: float = 0.5
    """N per mm of a push arrow"""
    camera: Any = None
    """the page's initial camera (position, look-at point), m; None: a humanoid's view"""
    shadows: bool = False
    """the page's lights cast shadows (each shadow-casting light renders the scene once more
    per frame: a browser without a GPU, WebGL in software, spends its CPU there)"""
    mesh_cell: float = LIVE_MESH_CELL
    """grid cell the robot's visual meshes are thinned on for the page, m (vertex clustering,
    :func:`wbc.viz.meshes.cluster`; 0: the full meshes). Software WebGL's cost per drawn frame
    grows with the triangles (benchmarks/live_view.md)"""
    pixel_ratio: float | None = None
    """the page's canvas pixels per CSS pixel, in its URL (viser's ``fixedDpr``); None: the
    browser's, lowered by viser when it draws slowly"""


def surface_spec(surface) -> dict | None:
    """A surface the page draws (a box, a half-space) as plain values; None for the others."""
    from ..sim.environment import Box, HalfSpace

    if isinstance(surface, Box):
        return {"kind": "box", "name": surface.name, "center": surface.center, "size": surface.size, "mu": surface.mu}
    if isinstance(surface, HalfSpace):
        return {"kind": "halfspace", "name": surface.name, "point": surface.point, "normal": surface.normal,
                "mu": surface.mu}
    return None


def view_spec(robot, environment=(), stack=None, options: PageOptions | None = None, **settings) -> dict:
    """What the drawing process needs, as plain values (:mod:`wbc.jsonable`: the pinocchio
    model as its own text serialisation, ``Model.saveToString``; see :class:`LiveView` for the
    arguments)."""
    o = PageOptions.of(options, settings, "view_spec")
    surfaces = [d for d in map(surface_spec, environment) if d is not None]
    return {"model": robot.model.saveToString(), "environment": surfaces, "host": o.host, "port": int(o.port),
            "fps": float(o.fps),
            "visual": {"urdf_path": str(robot.urdf_path), "root": robot.root, "package_dirs": list(robot.package_dirs),
                       "locked_joints": list(robot.locked_joints)},
            "tasks": [] if stack is None else task_specs(stack), "levels": 0 if stack is None else len(stack.levels),
            "contacts": [] if stack is None else [c.name for c in stack.contacts()], "speed": float(o.speed),
            "push_frames": tuple(o.frames), "shown_frames": tuple(o.shown_frames), "overlays": dict(o.overlays or {}),
            "force_scale": o.force_scale, "push_scale": o.push_scale, "shadows": bool(o.shadows),
            "mesh_cell": float(o.mesh_cell),
            "camera": ((2.2, -2.2, 1.6), (0.0, 0.0, 0.8)) if o.camera is None else tuple(map(tuple, o.camera))}


def page_url(host: str, port: int, pixel_ratio: float | None = None) -> str:
    """The live page's address; with ``pixel_ratio`` (:attr:`PageOptions.pixel_ratio`) its
    ``fixedDpr`` query, which viser's page reads (its canvas pixels per CSS pixel).

    Args:
        host: the address the page listens on (an IPv6 one is bracketed).
        port: its port.
        pixel_ratio: canvas pixels per CSS pixel (> 0), or None: the browser's.
    """
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/" + ("" if pixel_ratio is None else f"?fixedDpr={pixel_ratio:g}")


def page_command(msg: list) -> tuple | None:
    """(key, value) of a page's command as the drawing process sent it (``["post", key, value]``,
    decoded JSON: a key such as ``("kp", task)`` arrives as a list and is a tuple again, the
    mailbox's key); None for any other message."""
    if not msg or msg[0] != "post":
        return None
    key = tuple(msg[1]) if isinstance(msg[1], list) else msg[1]
    return key, msg[2]


def encode(snap, rows: bool = True) -> bytes:
    """A snapshot (:class:`wbc.runner.interactive.Snapshot`) as the drawing process reads it: its
    arrays and flags, and with ``rows`` the solution's diagnostics rows instead of the solution
    (else None: evaluating a solution's diagnostics, its levels' ranks and σ_min, costs about
    three control cycles, so :meth:`LiveView.publish` asks for them at most ``DIAG_HZ`` times per wall
    second and per simulated second)."""
    d = {k: getattr(snap, k) for k in ("t", "q", "points", "forces", "pushes", "targets", "normal", "levels",
                                       "disabled", "paused", "speed", "rtf", "done")}
    d["rows"] = None if not rows else diagnostics_rows(snap.sol) if snap.sol is not None else []
    d["overlays"] = getattr(snap, "overlays", None) or {}
    return jsonable.encode(d)


class LiveView:
    """The live view of a run (module docstring).

    Args:
        robot: the controller's :class:`~wbc.robot.RobotModel`.
        environment: the scenario's surfaces.
        stack: its stack (gizmos, sliders, plots); None: the robot only.
        options: the page's :class:`PageOptions` (None: its defaults).
        **settings: :class:`PageOptions` fields one by one (``host``, ``port``, ``fps``, ``speed``,
            ``frames``, ``shown_frames``, ``overlays``, ``force_scale``, ``push_scale``,
            ``camera``), over ``options``.
    """

    def __init__(self, robot, environment=(), stack=None, options: PageOptions | None = None, **settings) -> None:
        o = PageOptions.of(options, settings, "LiveView")
        _check_host(o.host)
        if o.mesh_cell < 0 or (o.pixel_ratio is not None and not o.pixel_ratio > 0):
            raise WbcError(f"LiveView: mesh_cell must be ≥ 0 and pixel_ratio > 0 (got {o.mesh_cell}, {o.pixel_ratio})")
        self.robot, self.host, self.fps = robot, o.host, float(o.fps)
        self.pixel_ratio = o.pixel_ratio
        spec = view_spec(robot, environment, stack, o)
        self.spec = spec
        self.slot = ss.SharedSlot()
        # messages both ways as JSON bytes (jsonable.send / receive): Connection's own send/recv pickle
        mine, theirs = socket.socketpair()
        self._conn = Connection(mine.detach())
        root = str(Path(__file__).resolve().parents[2])      # the tree this wbc comes from
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([root, *filter(None, [os.environ.get("PYTHONPATH")])]))
        # its own session: a Ctrl-C in the terminal reaches the control process, which stops it
        self.process = subprocess.Popen([sys.executable, "-m", "wbc.viz.drawing", str(theirs.fileno()), self.slot.name],
                                        pass_fds=(theirs.fileno(),), env=env, start_new_session=True)
        theirs.close()
        self._send_lock = threading.Lock()
        self._sent = 0
        self._poller = select.poll()
        self._poller.register(self._conn.fileno(), select.POLLIN)
        self._latest = None
        self._publish_ns = self._publish_max_ns = self._rows_ns = 0
        self._rows_t = -float("inf")
        self.published = 0
        try:
            jsonable.send(self._conn, spec)
            self.port = self._await_ready()
        except BaseException:
            self._end_process()
            self.slot.close()
            raise
        self.mailbox: Any = None        # the run's mailbox, once made (tests post to it)
        self.from_page: set = set()     # the keys the page has sent
        self.page_log: deque = deque(maxlen=PAGE_LOG)      # the page's last commands (key, value), in order
        self.page_commands = 0
        self._page_gone = False

    def _await_ready(self) -> int:
        t_end = time.monotonic() + START_TIMEOUT
        while time.monotonic() < t_end:
            if self._conn.poll(0.1):
                msg = jsonable.receive(self._conn)
                if msg[0] == "ready":
                    return int(msg[1])
                if msg[0] == "error":
                    raise WbcError(f"the live view could not start: {msg[1]}")
            elif self.process.poll() is not None:
                raise WbcError(f"the live view's drawing process ended at start (exit code {self.process.returncode})")
        raise WbcError(f"the live view's drawing process did not start within {START_TIMEOUT:.0f} s")

    @property
    def pid(self) -> int | None:
        """The drawing process's id."""
        return self.process.pid

    @property
    def url(self) -> str:
        """The page's address (:func:`page_url`)."""
        return page_url(self.host, self.port, self.pixel_ratio)

    # ------------------------------------------------------------------ control loop
    def publish(self, snap) -> None:
        """Hand ``snap`` to the drawing process (called by the control loop: never waits)."""
        t0 = time.perf_counter_ns()
        self._latest = snap
        # the rows at most DIAG_HZ times per wall second and per simulated second (a slow run's
        # publishes are fewer per wall second: they would all carry them)
        rows = snap.done or snap.paused or (t0 - self._rows_ns >= 1e9 / DIAG_HZ and snap.t >= self._rows_t + 1 / DIAG_HZ)
        if rows:
            self._rows_ns, self._rows_t = t0, snap.t
        self.slot.write(encode(snap, rows))
        self.published += 1
        dt = time.perf_counter_ns() - t0
        self._publish_ns += dt
        self._publish_max_ns = max(self._publish_max_ns, dt)

    def drain(self, mailbox) -> None:
        """Post the page's commands that arrived to ``mailbox`` (never waits; the control loop,
        through the mailbox's ``feed``, once per cycle)."""
        if self._page_gone or not self._poller.poll(0):      # a registered poll: 0.5 µs (Connection.poll: 6 µs)
            return
        try:
            while self._conn.poll():
                cmd = page_command(jsonable.receive(self._conn))
                if cmd is not None:
                    self.from_page.add(cmd[0])
                    self.page_log.append(cmd)
                    self.page_commands += 1
                    mailbox.post(*cmd)
        except (EOFError, OSError):      # the drawing process is gone: the run goes on without a page
            self._page_gone = True

    def latest(self):
        """The latest published snapshot (None before the first)."""
        return self._latest

    # ------------------------------------------------------------------ the drawing process's state
    def clients(self) -> int:
        """Browsers connected now that have drawn the scene once (a page counts from its first
        frame, not from its connection: it builds the meshes and compiles its shaders first)."""
        return int(self.slot.header[ss.CLIENTS])

    def stats(self) -> dict:
        """Frames drawn, wall time per drawn frame in the drawing process (mean and max, ms), its
        CPU time (s), and the control process's publish time per snapshot (mean and max, ms)."""
        h = self.slot.header
        frames = int(h[ss.FRAMES])
        return {"frames_drawn": frames, "draw_ms_mean": 1e-6 * int(h[ss.DRAW_NS]) / max(frames, 1),
                "draw_ms_max": 1e-6 * int(h[ss.DRAW_MAX_NS]), "drawing_cpu_s": 1e-9 * int(h[ss.CPU_NS]),
                "published": self.published, "publish_ms_mean": 1e-6 * self._publish_ns / max(self.published, 1),
                "publish_ms_max": 1e-6 * self._publish_max_ns}

    def wait_for_client(self, timeout: float | None = None) -> bool:
        """Block until a browser has connected and drawn the scene (True), or ``timeout`` s
        passed (False)."""
        t_end = None if timeout is None else time.perf_counter() + timeout
        while not self.clients():
            if t_end is not None and time.perf_counter() > t_end:
                return False
            time.sleep(0.05)
        return True

    def send(self, *msg) -> int:
        """A message to the drawing process: ``("overlay", name, on)``, ``("gizmos", names or None)``;
        returns its number (1, 2, …): :meth:`handled` reaches it once the drawing process has
        applied it."""
        with self._send_lock:
            jsonable.send(self._conn, msg)
            self._sent += 1
            return self._sent

    def handled(self) -> int:
        """How many of :meth:`send`'s messages the drawing process has applied."""
        return int(self.slot.header[ss.HANDLED])

    def _end_process(self) -> None:
        try:
            self.send("stop")
        except OSError:
            pass
        try:
            self.process.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()

    def close(self) -> None:
        """Stop the drawing process (and its server) and free the shared slot."""
        self._end_process()
        self._conn.close()
        self.slot.close()

