"""The live browser view (viser): the robot and its overlays drawn by a thread of their own, and
a page to act in (:mod:`wbc.viz.controls`).

The control loop only publishes (:meth:`LiveView.publish`: stores a reference to the latest
snapshot under a lock, a few µs); a drawing thread wakes ``fps`` times per wall second, takes
the latest snapshot if it is new, computes the visual geometry's placements on its own
``pinocchio.Data`` and sends the poses in one batch (``server.atomic()``). viser's server runs
its own event-loop thread; nothing in the control loop waits on it or on a browser.

Drawn: the robot's visual meshes (sent once per browser, then poses only), each CoM/frame task's
target as a gizmo (:mod:`wbc.viz.controls`), contact forces as arrows (1 mm per ``force_scale``
N), the CoM and its ground projection, the support polygon (convex hull of the loaded contact
points), pushes acting now (1 mm per 0.5 N), the priority diagnostics (HTML table, sacrificed
levels in red) and plots of each level's residual and each contact's normal force.

The page listens on 127.0.0.1 unless ``host`` says otherwise. A second tab gets the current
scene (viser replays its scene state to every new client). The viewer's page is viser's own
built client (no internet).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

from ..sim.environment import Box, HalfSpace
from .diagnostics import diagnostics_rows
from .meshes import geometry_mesh, visual_model

COLORS = {"target": (46, 134, 222), "com": (231, 76, 60), "support": (39, 174, 96), "force": (243, 156, 18),
          "push": (142, 68, 173)}
ROBOT_GREY = (125, 132, 145)
PLOT_SECONDS = 5.0          # s of simulated time in the live plots
PLOT_HZ = 5.0               # plot refreshes per wall second
DIAG_HZ = 5.0               # diagnostics table refreshes per wall second


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    q = pin.Quaternion(R)
    return np.array([q.w, q.x, q.y, q.z])


def _check_host(host: str) -> None:
    """Raise :class:`~wbc.errors.WbcError` if this machine cannot listen on ``host``."""
    import socket

    from ..errors import WbcError

    try:
        family = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)[0][0]
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((host, 0))
    except OSError as exc:
        raise WbcError(f"the live view could not listen on {host!r}: {exc}") from None


class LiveView:
    """See the module docstring. ``robot``: the controller's :class:`~wbc.robot.RobotModel`;
    ``environment``: the scenario's surfaces; ``host``/``port``: where the page listens (port 0:
    the first free one from 8080); ``fps``: drawing rate, frames per wall second."""

    def __init__(self, robot, environment=(), host: str = "127.0.0.1", port: int = 8080, fps: float = 30.0,
                 force_scale: float = 2.0, push_scale: float = 0.5) -> None:
        import viser

        _check_host(host)
        self.robot = robot
        self.fps = float(fps)
        self.force_scale, self.push_scale = force_scale, push_scale
        self.server = viser.ViserServer(host=host, port=port, label="wbc", verbose=False)
        self.host = host
        self.server.scene.set_up_direction("+z")
        self.server.initial_camera.position = (2.2, -2.2, 1.6)
        self.server.initial_camera.look_at = (0.0, 0.0, 0.8)
        self.data = robot.model.createData()
        self.geom = visual_model(robot)
        self.geom_data = pin.GeometryData(self.geom)
        self._lock = threading.Lock()
        self._latest = None
        self._seq = 0
        self._drawn = 0
        self.frames_drawn = 0
        self.draw_seconds = 0.0       # wall time the drawing thread spent drawing (s)
        self.overlays = {"contact forces": True, "CoM": True, "support polygon": True, "diagnostics": True}
        #: called in the drawing thread: with each new snapshot, with the recent ones (plots,
        #: PLOT_HZ), with a snapshot and its diagnostics rows (DIAG_HZ)
        self.on_snapshot: list[Callable] = []
        self.controls: Any = None       # the page's controls (wbc.viz.controls.Controls), once made
        self.mailbox: Any = None        # where they post
        self.on_plot: list[Callable] = []
        self.on_diagnostics: list[Callable] = []
        self._history: deque = deque(maxlen=600)
        self._last_plot = self._last_diag = 0.0
        self._robot_nodes()
        self._environment(environment)
        self._overlay_nodes()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._draw_loop, name="wbc-live-view", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ setup
    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.server.get_port()}/"

    def _robot_nodes(self) -> None:
        self.visuals = []
        for k, go in enumerate(self.geom.geometryObjects):
            mesh = geometry_mesh(go)
            if mesh is None:
                continue
            r, g, b = (int(255 * c) for c in np.asarray(go.meshColor)[:3])
            color = (r, g, b)
            if np.allclose(go.meshColor[:3], 0.9, atol=1e-3):     # pinocchio's default grey: darker on a light page
                color = ROBOT_GREY
            h = self.server.scene.add_mesh_simple(f"/robot/{k}", mesh[0], mesh[1], color=color)
            self.visuals.append((k, h))

    def _environment(self, environment) -> None:
        for i, s in enumerate(environment):
            if isinstance(s, Box):
                self.server.scene.add_box(f"/env/{s.name}", color=(141, 110, 99), dimensions=tuple(s.size),
                                          position=tuple(s.center))
            elif isinstance(s, HalfSpace):
                self.server.scene.add_box(f"/env/{s.name}{i}", color=(170, 175, 182), dimensions=(6.0, 6.0, 0.01),
                                          wxyz=tuple(_quat_wxyz(s.R)),
                                          position=tuple(s.point - 0.005 * s.normal), opacity=0.8)

    def _overlay_nodes(self) -> None:
        sc = self.server.scene
        self.com = sc.add_icosphere("/overlay/com", radius=0.02, color=COLORS["com"])
        self.com_ground = sc.add_cylinder("/overlay/com_ground", radius=0.02, height=0.002, color=COLORS["com"],
                                          opacity=0.6)
        self.support = sc.add_line_segments("/overlay/support", points=np.zeros((1, 2, 3), np.float32),
                                            colors=COLORS["support"], thickness=0.006)
        self.forces: Any = None       # contact-force segments (made at the first snapshot)
        self.pushes: Any = None

    # ------------------------------------------------------------------ control thread side
    def publish(self, snap) -> None:
        """Store the latest snapshot (called by the control loop: never waits on the page)."""
        with self._lock:
            self._latest = snap
            self._seq += 1

    def latest(self):
        """The latest published snapshot (None before the first)."""
        with self._lock:
            return self._latest

    # ------------------------------------------------------------------ drawing thread
    def _draw_loop(self) -> None:
        period = 1.0 / self.fps
        next_t = time.perf_counter()
        while not self._stop.is_set():
            with self._lock:
                snap, seq = self._latest, self._seq
            if snap is not None and seq != self._drawn:
                t0 = time.perf_counter()
                try:
                    self.draw(snap)
                except Exception as exc:      # a drawing error must not end the view silently
                    print(f"wbc: live view: drawing failed: {exc!r}", flush=True)
                self._drawn = seq
                self.frames_drawn += 1
                self.draw_seconds += time.perf_counter() - t0
            next_t += period
            delay = next_t - time.perf_counter()
            if delay < 0:
                next_t = time.perf_counter()
                delay = 0.0
            self._stop.wait(delay)

    def draw(self, snap) -> None:
        """Draw one snapshot (the drawing thread; callable directly, e.g. from a test)."""
        m, d = self.robot.model, self.data
        pin.forwardKinematics(m, d, snap.q)
        pin.updateGeometryPlacements(m, d, self.geom, self.geom_data)
        com = pin.centerOfMass(m, d, snap.q, False)
        with self.server.atomic():
            for k, h in self.visuals:
                M = self.geom_data.oMg[k]
                h.position = M.translation
                h.wxyz = _quat_wxyz(M.rotation)
            show = self.overlays
            self.com.visible = self.com_ground.visible = show["CoM"]
            if show["CoM"]:
                self.com.position = com
                self.com_ground.position = (com[0], com[1], 0.001)
            self._draw_contacts(snap)
            for cb in self.on_snapshot:
                cb(snap)
        now = time.perf_counter()
        self._history.append(snap)
        if now - self._last_plot > 1.0 / PLOT_HZ:
            self._last_plot = now
            for cb in self.on_plot:
                cb(list(self._history))
        if now - self._last_diag > 1.0 / DIAG_HZ:
            self._last_diag = now
            for cb in self.on_diagnostics:
                cb(snap, diagnostics_rows(snap.sol) if snap.sol is not None else [])

    def _draw_contacts(self, snap) -> None:
        sc = self.server.scene
        n = np.linalg.norm(snap.forces, axis=1) if len(snap.forces) else np.zeros(0)
        loaded = n > 1e-3
        if self.forces is None and len(snap.points):      # one segment per contact point, kept
            self.forces = sc.add_line_segments("/overlay/forces", np.zeros((len(snap.points), 2, 3), np.float32),
                                               colors=COLORS["force"], thickness=0.008)
        if self.forces is not None:
            self.forces.visible = self.overlays["contact forces"]
            if self.overlays["contact forces"]:
                ends = snap.points + snap.forces / self.force_scale * 1e-3
                self.forces.points = np.stack([snap.points, ends], axis=1).astype(np.float32)
        pts = snap.points[loaded] if len(snap.points) else snap.points
        self.support.visible = self.overlays["support polygon"]
        if self.overlays["support polygon"] and len(pts) >= 3:
            from scipy.spatial import ConvexHull, QhullError

            try:
                hull = pts[ConvexHull(pts[:, :2]).vertices] + np.array([0.0, 0.0, 0.002])
                self.support.points = np.stack([hull, np.roll(hull, -1, axis=0)], axis=1).astype(np.float32)
            except QhullError:      # collinear points: keep the last polygon
                pass
        if self.pushes is not None:
            self.pushes.remove()
            self.pushes = None
        if snap.pushes:
            segs = []
            for frame, force in snap.pushes:
                fid = self.robot.frame_id(frame)
                pin.updateFramePlacement(self.robot.model, self.data, fid)
                end = self.data.oMf[fid].translation
                fn = float(np.linalg.norm(force))
                length = max(fn / self.push_scale * 1e-3, 0.05)
                segs.append(np.stack([end - force / max(fn, 1e-9) * length, end]))
            self.pushes = sc.add_arrows("/overlay/pushes", np.array(segs, np.float32), COLORS["push"],
                                        shaft_radius=0.01, head_radius=0.025, head_length=0.05)

    def wait_for_client(self, timeout: float | None = None) -> bool:
        """Block until a browser has connected (True), or ``timeout`` s passed (False)."""
        t_end = None if timeout is None else time.perf_counter() + timeout
        while not self.server.get_clients():
            if t_end is not None and time.perf_counter() > t_end:
                return False
            time.sleep(0.05)
        return True

    def close(self) -> None:
        """Stop the drawing thread and the server."""
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.server.stop()
