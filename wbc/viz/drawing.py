"""The live view's drawing process: the viser server, the scene, the page's controls and plots.

Started by :class:`wbc.viz.live.LiveView` (``python -m wbc.viz.drawing FD SLOT``: a connection on
the inherited socket FD, the shared slot's name), which sends first a plain description
of the scene (:func:`wbc.viz.live.view_spec`: the pinocchio model, the URDF to read the meshes
from, the surfaces, the tasks' names, kinds and slider ranges). Nothing here runs in the control
process: its interpreter lock, its CPU time and viser's event loop are this process's own.

:func:`main` loops ``fps`` times per wall second: it takes the latest encoded snapshot from the
shared slot (:mod:`wbc.viz.shared_state`) if it is new, computes the visual geometry's placements
on its own ``pinocchio.Data`` and sends the poses in one batch (``server.atomic()``); it answers
the control process's messages on the pipe (``("stop",)``, ``("overlay", name, on)``,
``("gizmos", names)``). The page's commands go the other way on the same pipe, as
``("post", key, value)`` (:class:`Poster`).

Drawn: the robot's visual meshes (sent once per browser, then poses only), each CoM/frame task's
target as a gizmo (:mod:`wbc.viz.controls`), contact forces as arrows (1 mm per ``force_scale`` N),
the CoM and its ground projection, the support polygon (convex hull of the loaded contact points),
pushes acting now (1 mm per ``push_scale`` N), the shown frames' axes (a glass), the overlays of
:mod:`wbc.viz.overlays`, the priority diagnostics (HTML table, sacrificed levels in red) and plots
of each level's residual and each contact's normal force.
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import numpy as np
import pinocchio as pin

from .. import jsonable
from ..sim.environment import Box, HalfSpace
from . import shared_state as ss
from .controls import Controls
from .meshes import cluster, geometry_mesh, visual_model
from .overlays import Overlays
from .viser_quiet import quiet_closed_handshakes

COLORS = {"target": (46, 134, 222), "com": (231, 76, 60), "support": (39, 174, 96), "force": (243, 156, 18),
          "push": (142, 68, 173)}
ROBOT_GREY = (125, 132, 145)
PLOT_HZ = 5.0               # plot refreshes per wall second
AXES_LENGTH = 0.1           # m: a shown frame's axes
MIN_ARROW = 1e-3            # m: shorter arrows are hidden
NICE = 10                   # the drawing process's niceness increment (lower priority than the loop)
FIRST_FRAMES = 3               # render requests a page answers before it counts as drawing the scene
FIRST_FRAME_TIMEOUT = 300.0     # s: a page's first frame (a software renderer on a loaded machine is slow)
POSE_TOLERANCE = 1e-4       # m and quaternion units: a mesh that moved less keeps its last sent pose


def quat_wxyz(R: np.ndarray) -> np.ndarray:
    q = pin.Quaternion(R)
    return np.array([q.w, q.x, q.y, q.z])


class Poster:
    """The page's side of the mailbox: ``post(key, value)`` sends the command to the control
    process (thread-safe: viser runs its callbacks on threads of its own)."""

    def __init__(self, conn) -> None:
        self.conn, self._lock = conn, threading.Lock()
        self.posted = 0

    def post(self, key, value) -> None:
        with self._lock:
            try:
                jsonable.send(self.conn, ("post", key, value))
                self.posted += 1
            except OSError:            # the control process is gone: nothing to act on
                pass


class Drawer:
    """The scene and its server (see the module docstring); ``spec``: :func:`wbc.viz.live.view_spec`."""

    def __init__(self, spec: dict, poster: Poster) -> None:
        import viser

        self.spec = spec
        self.model = pin.Model()
        self.model.loadFromString(spec["model"])       # the controller's model (Model.saveToString)
        self.fps = float(spec["fps"])
        self.force_scale, self.push_scale = spec["force_scale"], spec["push_scale"]
        # a browser's spare connection closed unused: no traceback (wbc.viz.viser_quiet)
        self.closed_handshakes = quiet_closed_handshakes()
        self.server = viser.ViserServer(host=spec["host"], port=spec["port"], label="wbc", verbose=False)
        self.server.scene.set_up_direction("+z")
        self.server.scene.configure_default_lights(cast_shadow=bool(spec.get("shadows", False)))
        self.server.initial_camera.position, self.server.initial_camera.look_at = spec.get(
            "camera", ((2.2, -2.2, 1.6), (0.0, 0.0, 0.8)))
        self.data = self.model.createData()
        self.geom = visual_model(SimpleNamespace(**spec["visual"]))
        self.geom_data = pin.GeometryData(self.geom)
        self.frames_drawn = 0
        self.draw_ns = self.draw_max_ns = 0
        self.overlays = {"contact forces": True, "CoM": True, "support polygon": True, "frames": True,
                         "diagnostics": True}
        #: called with each new snapshot, with the recent ones (plots, PLOT_HZ), with a snapshot that
        #: carries the diagnostics rows
        self.on_snapshot: list[Callable] = []
        self.on_plot: list[Callable] = []
        self.on_diagnostics: list[Callable] = []
        self._history: deque = deque(maxlen=600)
        self._last_plot = 0.0
        self._robot_nodes()
        self._environment(spec["environment"])
        self._overlay_nodes()
        self.extra = Overlays(self)
        self.controls = Controls(self, spec, poster)
        self._drawn_ids: set = set()       # the pages that have drawn the scene once (drawn_clients)
        self.server.on_client_connect(self._await_first_frame)

    def _await_first_frame(self, client) -> None:
        """Count ``client`` once its page has drawn a frame of the scene: viser calls a client
        connected at its first camera message, before the page has built the meshes and compiled
        its shaders (seconds of CPU for a browser rendering in software). A render request
        (``get_render``, 16×16 px) returns once the page has drawn a frame; the first may come
        before the scene's meshes are mounted (the page applies its messages in a frame, React
        mounts their objects after it), so ``FIRST_FRAMES`` of them, one after the other: the
        later ones draw the meshes (benchmarks/live_view.md: with one, the page then stalled
        for the run's first 20 s)."""
        def wait() -> None:
            try:
                for _ in range(FIRST_FRAMES):
                    client.get_render(16, 16, timeout=FIRST_FRAME_TIMEOUT)
            except Exception:       # gone, or never drew: not counted
                return
            self._drawn_ids.add(client.client_id)

        threading.Thread(target=wait, daemon=True).start()

    def drawn_clients(self) -> int:
        """The connected pages that have drawn the scene (:meth:`_await_first_frame`)."""
        return len(self._drawn_ids & set(self.server.get_clients()))

    # ------------------------------------------------------------------ setup
    def _robot_nodes(self) -> None:
        self.visuals = []
        for k, go in enumerate(self.geom.geometryObjects):
            mesh = geometry_mesh(go)
            if mesh is None:
                continue
            mesh = cluster(*mesh, float(self.spec.get("mesh_cell", 0.0)))     # PageOptions.mesh_cell
            r, g, b = (int(255 * c) for c in np.asarray(go.meshColor)[:3])
            color = (r, g, b)
            if np.allclose(go.meshColor[:3], 0.9, atol=1e-3):     # pinocchio's default grey: darker on a light page
                color = ROBOT_GREY
            h = self.server.scene.add_mesh_simple(f"/robot/{k}", mesh[0], mesh[1], color=color)
            self.visuals.append((k, h))
        self._poses = np.zeros((len(self.visuals), 7))
        self._sent = np.full((len(self.visuals), 7), np.inf)     # the poses last sent (none yet)

    def _environment(self, environment) -> None:
        """The surfaces (:func:`wbc.viz.live.surface_spec`: plain values) as boxes."""
        built = [Box(d["center"], d["size"], d["mu"], d["name"]) if d["kind"] == "box" else
                 HalfSpace(d["point"], d["normal"], d["mu"], d["name"]) for d in environment]
        for i, s in enumerate(built):
            if isinstance(s, Box):
                self.server.scene.add_box(f"/env/{s.name}", color=(141, 110, 99), dimensions=tuple(s.size),
                                          position=tuple(s.center))
            elif isinstance(s, HalfSpace):
                self.server.scene.add_box(f"/env/{s.name}{i}", color=(170, 175, 182), dimensions=(6.0, 6.0, 0.01),
                                          wxyz=tuple(quat_wxyz(s.R)),
                                          position=tuple(s.point - 0.005 * s.normal), opacity=0.8)

    def _overlay_nodes(self) -> None:
        sc = self.server.scene
        self.com = sc.add_icosphere("/overlay/com", radius=0.02, color=COLORS["com"])
        self.com_ground = sc.add_cylinder("/overlay/com_ground", radius=0.02, height=0.002, color=COLORS["com"],
                                          opacity=0.6)
        self.support = sc.add_line_segments("/overlay/support", points=np.zeros((1, 2, 3), np.float32),
                                            colors=COLORS["support"], thickness=0.006)
        self.shown_frames = [(name, self.model.getFrameId(name), sc.add_frame(
            f"/frames/{name}", axes_length=AXES_LENGTH, axes_radius=0.006)) for name in self.spec["shown_frames"]]
        self._arrows: dict[str, Any] = {}      # path -> arrows handle (set_arrows)

    # ------------------------------------------------------------------ drawing
    def draw(self, snap) -> None:
        """Draw one decoded snapshot (a namespace of the payload's keys)."""
        m, d = self.model, self.data
        pin.forwardKinematics(m, d, snap.q)
        pin.updateGeometryPlacements(m, d, self.geom, self.geom_data)
        com = pin.centerOfMass(m, d, snap.q, False)
        poses = self._poses
        for i, (k, _) in enumerate(self.visuals):
            M = self.geom_data.oMg[k]
            poses[i, :3] = M.translation
            poses[i, 3:] = quat_wxyz(M.rotation)
        # only the meshes that moved by more than POSE_TOLERANCE since they were last sent: each pose
        # set costs viser ~0.1 ms of Python (a comparison and a message), most of a frame's time
        moved = np.flatnonzero(np.max(np.abs(poses - self._sent), axis=1) > POSE_TOLERANCE)
        self._sent[moved] = poses[moved]
        with self.server.atomic():
            for j in moved.tolist():
                h = self.visuals[j][1]
                h.position = poses[j, :3]
                h.wxyz = poses[j, 3:]
            show = self.overlays
            self.com.visible = self.com_ground.visible = show["CoM"]
            if show["CoM"]:
                self.com.position = com
                self.com_ground.position = (com[0], com[1], 0.001)
            for _name, fid, axes in self.shown_frames:
                axes.visible = show["frames"]
                if show["frames"]:
                    pin.updateFramePlacement(m, d, fid)
                    axes.position = d.oMf[fid].translation
                    axes.wxyz = quat_wxyz(d.oMf[fid].rotation)
            self._draw_contacts(snap)
            self.extra.draw(snap)
            for cb in self.on_snapshot:
                cb(snap)
        now = time.perf_counter()
        self._history.append(snap)
        if now - self._last_plot > 1.0 / PLOT_HZ:
            self._last_plot = now
            for cb in self.on_plot:
                cb(list(self._history))
        if snap.rows is not None:       # DIAG_HZ per wall second (wbc.viz.live.DIAG_HZ)
            for cb in self.on_diagnostics:
                cb(snap)

    def set_arrows(self, path: str, segments: list, color, shaft: float, head: float) -> None:
        """Arrows ``path`` for ``segments`` [(start, end)] (m), ``color`` one RGB or one per arrow:
        updated in place while their count stays, remade when it changes, hidden when none."""
        h = self._arrows.get(path)
        if h is not None and not segments:
            h.visible = False
            return
        if not segments:
            return
        pts = np.array(segments, np.float32)
        colors = np.asarray(color, np.uint8)
        if h is not None and h.points.shape == pts.shape:
            h.points = pts
            if colors.ndim == 2:
                h.colors = colors
            h.visible = True
            return
        if h is not None:
            h.remove()
        self._arrows[path] = self.server.scene.add_arrows(path, pts, colors, shaft_radius=shaft, head_radius=head,
                                                          head_length=2.5 * head)

    def _draw_contacts(self, snap) -> None:
        n = np.linalg.norm(snap.forces, axis=1) if len(snap.forces) else np.zeros(0)
        loaded = n > 1e-3
        segs = []
        if self.overlays["contact forces"]:
            for p, f, fn in zip(snap.points, snap.forces, n):
                if fn / self.force_scale * 1e-3 > MIN_ARROW:
                    segs.append((p, p + f / self.force_scale * 1e-3))
        self.set_arrows("/overlay/forces", segs, COLORS["force"], 0.004, 0.01)
        pts = snap.points[loaded] if len(snap.points) else snap.points
        self.support.visible = self.overlays["support polygon"]
        if self.overlays["support polygon"] and len(pts) >= 3:
            from scipy.spatial import ConvexHull, QhullError

            try:
                hull = pts[ConvexHull(pts[:, :2]).vertices] + np.array([0.0, 0.0, 0.002])
                self.support.points = np.stack([hull, np.roll(hull, -1, axis=0)], axis=1).astype(np.float32)
            except QhullError:      # collinear points: keep the last polygon
                pass
        segs = []
        for frame, force in snap.pushes:
            fid = self.model.getFrameId(frame)
            pin.updateFramePlacement(self.model, self.data, fid)
            end = self.data.oMf[fid].translation
            fn = float(np.linalg.norm(force))
            length = max(fn / self.push_scale * 1e-3, 0.05)
            segs.append((end - force / max(fn, 1e-9) * length, end))
        self.set_arrows("/overlay/pushes", segs, COLORS["push"], 0.01, 0.025)

    # ------------------------------------------------------------------ messages from the control process
    def handle(self, msg) -> bool:
        """Apply a control-process message; False on ``("stop",)``."""
        if msg[0] == "stop":
            return False
        if msg[0] == "overlay":
            self.set_overlay(msg[1], bool(msg[2]))
        elif msg[0] == "gizmos":
            for name, g in self.controls.gizmos.items():
                g.visible = msg[1] is None or name in msg[1]
        return True

    def set_overlay(self, name: str, on: bool) -> None:
        """Show or hide an overlay (the page's checkbox follows)."""
        self.overlays[name] = on
        box = self.controls.overlay_boxes.get(name)
        if box is not None and box.value != on:
            box.value = on


def lower_priority(nice: int) -> None:
    """Run this process ``nice`` steps below its priority. With the kernel's session autogroups
    (``kernel.sched_autogroup_enabled``, Linux's default on desktops) a nice value only orders the
    processes of one session, and this one has a session of its own (a Ctrl-C in the terminal is
    not for it): its session's group gets the same lower weight (``/proc/self/autogroup``), or the
    scheduler would still share the CPU equally between it and the control process."""
    try:
        os.nice(nice)
    except OSError:         # not permitted here: the default priority
        pass
    try:
        with open("/proc/self/autogroup", "w") as f:
            f.write(str(nice))
    except OSError:         # no autogroups (not Linux, or the kernel's sysctl off): the nice value is enough
        pass


def main(conn, slot_name: str) -> None:
    """The drawing process's body (see the module docstring): the spec comes first on ``conn``.
    It runs at a lower scheduling priority (``NICE``): on a machine with few cores the control
    loop gets the CPU first, the drawing what is left."""
    lower_priority(NICE)
    spec = jsonable.receive(conn)
    poster = Poster(conn)
    try:
        drawer = Drawer(spec, poster)
    except Exception as exc:          # reported by LiveView in the control process
        jsonable.send(conn, ("error", f"{type(exc).__name__}: {exc}"))
        return
    slot = ss.SharedSlot(slot_name)
    jsonable.send(conn, ("ready", drawer.server.get_port()))
    period, next_t, running, handled = 1.0 / drawer.fps, time.perf_counter(), True, 0
    parent = os.getppid()
    try:
        while running and os.getppid() == parent:
            try:
                while running and conn.poll():
                    running = drawer.handle(jsonable.receive(conn))
                    handled += 1
            except (EOFError, OSError):          # the control process closed its end
                break
            payload = slot.read_new()
            if payload is not None:
                t0 = time.perf_counter_ns()
                try:
                    drawer.draw(SimpleNamespace(**jsonable.decode(payload)))
                except Exception as exc:      # a drawing error must not end the view silently
                    print(f"wbc: live view: drawing failed: {exc!r}", flush=True)
                dt = time.perf_counter_ns() - t0
                drawer.frames_drawn += 1
                drawer.draw_ns += dt
                drawer.draw_max_ns = max(drawer.draw_max_ns, dt)
            slot.set_stats(drawer.frames_drawn, drawer.draw_ns, drawer.draw_max_ns, drawer.drawn_clients(),
                           time.process_time_ns(), handled)
            next_t += period
            delay = next_t - time.perf_counter()
            if delay < 0:
                next_t, delay = time.perf_counter(), 0.0
            time.sleep(delay)
    finally:
        drawer.server.stop()
        slot.close()


if __name__ == "__main__":      # python -m wbc.viz.drawing FD SLOT (started by wbc.viz.live.LiveView)
    import sys
    from multiprocessing.connection import Connection

    main(Connection(int(sys.argv[1])), sys.argv[2])
