"""A Meshcat scene of a running scenario.

Draws the robot with its meshes (pinocchio's MeshcatVisualizer on the URDF's visual
geometry), the environment, each CoM/frame task's target, the CoM and its ground
projection, the support polygon, the contact forces as arrows scaled by magnitude
(1 mm per ``force_scale`` N, default 2 N) and external pushes while they act (pointing at
the pushed frame, 1 mm per ``push_scale`` N, default 0.5 N: 2 mm per N, at least
``PUSH_MIN_LENGTH`` m).

Interaction (:meth:`Scene.set_targets`): each force task (:class:`~wbc.tasks.Force`) gets
two arrows at its contact's point, both the force the environment applies to the robot
along the task's directions S_f (their force part, in the world): the desired force
S_f λ_D (a wide translucent teal sleeve) and the measured force the task uses, S_f λ_m with
λ_m = S_fᵀ f_m (a thin opaque pink core inside it), both drawn over the robot (the hand
would hide them), 1 mm per ``task_force_scale`` N
(default 0.1 N: 1 cm per N, 10 N = 10 cm; the contact-force scale would draw 10 N as 5 mm);
the diagnostics panel gives their values under the same colours. ``frames=[...]`` draws
those robot frames' actual axes (12 cm triads; the targets' are 8 cm): the glass's frame
in a glass scenario, so its tilt shows against the target's axes.

``Scene(robot, environment)`` starts a Meshcat server whose page listens on 127.0.0.1
only, or on ``host`` (:mod:`wbc.viz.server`; the viewer's JavaScript comes from the
installed ``meshcat`` package: no internet).
``record=True`` keeps every frame for :meth:`save_html`, a self-contained page
that replays the run offline.

Priority diagnostics (:meth:`Scene.show_diagnostics`, per level residual, rank and
σ_min of J̄_k, sacrificed tasks, active constraints): live, a head-up table drawn as
a texture on a panel attached to the camera (meshcat 0.3.2's server forwards scene
commands only, no text or controls); in a recording, an HTML panel that follows the
replay's clock.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from ..sim.environment import Box, Cylinder, HalfSpace, Sphere
from ..tasks.collision_avoidance import CollisionAvoidance
from ..tasks.com import CoM
from ..tasks.force import Force
from ..tasks.frame import Frame
from . import server
from .collisions import add_witness_nodes, draw_witness_slots
from .diagnostics import overlay_html, render_png, table_lines
from .keyframes import thin_animation
from .meshcat_quiet import Animation, MeshcatVisualizer, meshcat, mg, mt
from .meshes import cluster, geometry_mesh, visual_model
from .scene_options import SceneOptions
from .task_forces import task_forces

HIDDEN = np.diag([0.0, 0.0, 0.0, 1.0])   # a zero-scale transform: hides a node on the live page
#: a hidden node's scale in a recording (with a ``visible`` track set to false; not 0: singular matrices)
HIDDEN_SCALE = (1e-6, 1e-6, 1e-6)
COLORS = {"target": 0x2E86DE, "com": 0xE74C3C, "support": 0x27AE60, "force": 0xF39C12, "push": 0x8E44AD,
          "desired": 0x16A085, "measured": 0xD81B60}
PUSH_MIN_LENGTH = 0.05       # m: the shortest push arrow drawn
TASK_FORCE_RADII = {"desired": 0.012, "measured": 0.005}   # m: the sleeve and its core
FRAME_AXES = 0.12            # m: the axes of a frame drawn where it is (frames=...)


#: a node under the camera object: it moves with the view (a head-up display)
HUD_PATH = "/Cameras/default/rotated/<object>/wbc_diagnostics"
HUD_FOV = np.deg2rad(75.0)       # meshcat's default camera
HUD_ASPECT = 4.0 / 3.0           # anchored to the left edge of a 4:3 view (wider windows: a bit inset)


class _OnTopMesh(mg.Mesh):
    """A mesh drawn after everything else (with a material whose depthTest is off); a
    higher ``order`` is drawn later (over a lower one)."""

    def __init__(self, geometry, material, order: int = 1000) -> None:
        super().__init__(geometry, material)
        self.order = order

    def lower(self):
        data = super().lower()
        data["object"]["renderOrder"] = self.order
        return data


def _arrow_pose(origin: np.ndarray, vec: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """(rigid transform, scale) taking meshcat's unit cylinder (axis y, centred) onto the
    segment origin → origin + length·vec/|vec|: the scale is (1, length, 1), in the
    cylinder's frame (applied before the rigid transform)."""
    d = vec / max(np.linalg.norm(vec), 1e-12)
    y = np.array([0.0, 1.0, 0.0])
    axis = np.cross(y, d)
    s, c = np.linalg.norm(axis), float(y @ d)
    R = np.eye(3) if s < 1e-9 else pin.exp3(axis / s * np.arctan2(s, c))
    if s < 1e-9 and c < 0:
        R = np.diag([1.0, -1.0, -1.0])
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = origin + 0.5 * length * d
    return T, np.array([1.0, length, 1.0])


def _three_decomposition(T: np.ndarray, scale) -> tuple[np.ndarray, list[float]]:
    """T·diag(scale) (T rigid) as (rigid transform, scale) the way three.js's
    ``Matrix4.decompose`` splits it (a negative determinant goes to the x scale): a
    mirrored mesh, scale (1, -1, 1), becomes scale (-1, 1, 1) after a rotation. A
    recording keys the same values as the live page's matrix gives, so that whichever
    of the static scene and the animation a replay page applies last, it shows the same."""
    s = np.asarray(scale, float)
    canonical = np.abs(s)
    if np.prod(s) < 0:
        canonical[0] = -canonical[0]
    R = T.copy()
    R[:3, :3] = T[:3, :3] @ np.diag(np.sign(s) * np.sign(canonical))   # a proper rotation
    return R, [float(x) for x in canonical]


class Scene:
    """See the module docstring.

    Args:
        robot: the robot drawn.
        environment: shapes of :mod:`wbc.sim.environment` drawn.
        open_browser: open the page in a browser.
        zmq_url: draw through a Meshcat server already running there; None: start one.
        host: the address the started server's page listens on.
        options: :class:`SceneOptions` (None: its defaults).
        **settings: its fields one by one (``record``, ``live``, ``fps``, ``force_scale``,
            ``push_scale``, ``task_force_scale``, ``mesh_cell``), over ``options``.
    """

    def __init__(self, robot, environment=(), open_browser: bool = False, zmq_url: str | None = None,
                 host: str = server.DEFAULT_HOST, options: SceneOptions | None = None, **settings) -> None:
        o = self.options = SceneOptions.of(options, settings, "Scene")
        record, live, fps, mesh_cell = o.record, o.live, o.fps, o.mesh_cell
        force_scale, push_scale, task_force_scale = o.force_scale, o.push_scale, o.task_force_scale
        self.robot = robot
        self.server = None          # the server process this scene started (stopped by close)
        if not zmq_url:
            self.server, zmq_url, _ = server.start(host)
        self.vis = meshcat.Visualizer(zmq_url=zmq_url)
        if open_browser:
            self.vis.open()
        self.vis.delete()
        self.geom = visual_model(robot)
        self.viz = MeshcatVisualizer(robot.model, self.geom, self.geom)
        self.viz.initViewer(viewer=self.vis, loadModel=False)
        self.mesh_cell = mesh_cell
        self._load_robot()
        self.force_scale = force_scale
        self.push_scale = push_scale
        self.task_force_scale = task_force_scale
        self.frames: list[str] = []     # robot frames drawn with their axes where they are
        self._legend: list[tuple[str, str]] = []   # the force tasks' lines of the diagnostics panel
        self.record = record
        self.anim = Animation(default_framerate=fps) if record else None
        self.live = (not record) if live is None else bool(live)   # draw to the server's page too
        self._target = None        # where _draw writes: None (the live scene) or an animation frame
        self._poses: dict[str, np.ndarray] = {}   # recording: each node's last rigid transform
        self._witness_tasks: set[str] = set()      # collision tasks whose witness slots exist
        self._frame = 0
        self._diag_frames: list[int] = []
        self._diag_text: list[list[tuple[str, str]]] = []
        self.hud_box: tuple[float, float, float, float] | None = None
        self._env(environment)
        self.vis["overlay/com"].set_object(mg.Sphere(0.02), mg.MeshLambertMaterial(color=COLORS["com"]))
        self.vis["overlay/com_ground"].set_object(mg.Cylinder(0.002, 0.02),
                                                  mg.MeshLambertMaterial(color=COLORS["com"], opacity=0.6))

    @property
    def url(self) -> str:
        return self.vis.url()

    def _node_name(self, go) -> str:
        return f"robot/visuals/{go.name}"

    def _load_robot(self) -> None:
        """Each visual as an indexed triangle mesh (:mod:`wbc.viz.meshes`: the URDF's mesh scale
        baked in, thinned on a ``mesh_cell`` grid), flat-shaded (the page derives the normals):
        a replay holds each mesh once, 12 bytes per vertex and per face."""
        for go in self.geom.geometryObjects:
            mesh = geometry_mesh(go)
            if mesh is None:
                continue
            v, f = cluster(*mesh, self.mesh_cell)
            color = int(np.dot(np.clip(np.asarray(go.meshColor[:3]) * 255, 0, 255).astype(int), [65536, 256, 1]))
            self.vis[self._node_name(go)].set_object(
                mg.TriangularMeshGeometry(v, f),
                mg.MeshLambertMaterial(color=color, opacity=float(go.meshColor[3]), flatShading=True))

    def _env(self, environment) -> None:
        for i, s in enumerate(environment):
            if isinstance(s, Box):
                self.vis[f"env/{s.name}"].set_object(mg.Box(s.size), mg.MeshLambertMaterial(color=0x8D6E63))
                self.vis[f"env/{s.name}"].set_transform(mt.translation_matrix(s.center))
            elif isinstance(s, Sphere):
                self.vis[f"env/{s.name}"].set_object(mg.Sphere(s.radius), mg.MeshLambertMaterial(color=0x8D6E63))
                self.vis[f"env/{s.name}"].set_transform(mt.translation_matrix(s.center))
            elif isinstance(s, Cylinder):       # meshcat's cylinder is along y; the obstacle's along z
                self.vis[f"env/{s.name}"].set_object(mg.Cylinder(s.length, s.radius),
                                                     mg.MeshLambertMaterial(color=0x8D6E63))
                self.vis[f"env/{s.name}"].set_transform(mt.translation_matrix(s.center)
                                                        @ mt.rotation_matrix(np.pi / 2, [1, 0, 0]))
            elif isinstance(s, HalfSpace):
                T = np.eye(4)
                T[:3, :3] = s.R
                T[:3, 3] = s.point - 0.005 * s.normal
                self.vis[f"env/{s.name}{i}"].set_object(mg.Box([6.0, 6.0, 0.01]),
                                                        mg.MeshLambertMaterial(color=0xD5D8DC, opacity=0.8))
                self.vis[f"env/{s.name}{i}"].set_transform(T)

    def set_targets(self, stack, frames=()) -> None:
        """One marker per CoM/frame task (created once; positions follow the targets); a frame
        task that holds an orientation also gets the target frame's axes (x red, y green, z
        blue, 8 cm: the glass's frame in an interaction scenario). Each force task gets its
        desired and measured force arrows (module docstring); each robot frame named in
        ``frames`` its actual axes (12 cm)."""
        for name in frames:
            self.robot.frame_id(name)        # a KeyError-like error now, not mid-run
            self.vis[f"frames/{name}"].set_object(mg.triad(FRAME_AXES))
        self.frames = list(frames)
        for t in stack:
            if isinstance(t, Force) and t.contact in stack:
                # hidden (tiny) along the task's first direction: a replay's rotation track then
                # starts where the arrow will point (three.js skips writing a track's value while it
                # stays the same, so a rotation keyed constant from the start must be right from it)
                S = t.selection(stack[t.contact].surface(self.robot).force_dim)[0]
                rest = _arrow_pose(np.zeros(3), S[:3, 0] if np.linalg.norm(S[:3, 0]) > 1e-9 else np.eye(3)[2], 1.0)[0]
                for part, radius in TASK_FORCE_RADII.items():
                    node = self.vis[f"task_forces/{t.name}/{part}"]
                    # drawn over the robot (the hand above the pad would hide them), the core over the sleeve
                    node.set_object(_OnTopMesh(mg.Cylinder(1.0, radius), mg.MeshLambertMaterial(
                        color=COLORS[part], opacity=0.45 if part == "desired" else 1.0,
                        transparent=part == "desired", depthTest=False, depthWrite=False),
                        order=900 if part == "desired" else 901))
                    node.set_transform(rest @ np.diag([*HIDDEN_SCALE, 1.0]))
                    self._poses[f"task_forces/{t.name}/{part}"] = rest
            if isinstance(t, (CoM, Frame)) and t.target is not None:
                node = self.vis[f"targets/{t.name}"]
                node.set_object(mg.Sphere(0.015 if isinstance(t, Frame) else 0.025),
                                mg.MeshLambertMaterial(color=COLORS["target"], opacity=0.7))
                if t.moves_orientation:
                    node["axes"].set_object(mg.triad(0.08))

    def _node(self, path: str):
        return self.vis[path] if self._target is None else self._target[path]

    def _place(self, path: str, T: np.ndarray, scale=None, hideable: bool = False) -> None:
        """Place a node with a rigid transform T and a scale (in the node's frame: T·diag(scale)).
        Live: one matrix. Recording: meshcat's animation keeps position and quaternion only
        (a scaled or mirrored matrix would give a wrong rotation, and its scale would be lost),
        so the scale goes in its own ``scale`` track, and a ``hideable`` node (one that
        :meth:`_hide` may hide) gets a ``visible`` track too."""
        node = self._node(path)
        if self._target is None:
            node.set_transform(T if scale is None else T @ np.diag([*scale, 1.0]))
            return
        if scale is not None:
            T, scale = _three_decomposition(T, scale)
            node.set_property("scale", "vector3", scale)
        node.set_transform(T)
        if hideable:
            node.set_property("visible", "boolean", True)
            self._poses[path] = T

    def _hide(self, path: str) -> None:
        """Hide a node. Live: the zero-scale ``HIDDEN`` transform. Recording: ``visible``
        false (the animation player steps booleans: hidden from this frame to the next one
        that shows it) and a tiny scale, at the node's last pose (so that the scale, linearly
        interpolated between frames, shrinks the arrow in place)."""
        node = self._node(path)
        if self._target is None:
            node.set_transform(HIDDEN)
            return
        node.set_transform(self._poses.get(path, np.eye(4)))
        node.set_property("scale", "vector3", list(HIDDEN_SCALE))
        node.set_property("visible", "boolean", False)

    def add_arrow(self, name: str, color: int, radius: float = 0.008) -> None:
        """An arrow ``extras/<name>`` that :meth:`show` places with ``arrows={name: ...}``
        (hidden until then)."""
        self.vis[f"extras/{name}"].set_object(mg.Cylinder(1.0, radius), mg.MeshLambertMaterial(color=color))
        self.vis[f"extras/{name}"].set_transform(HIDDEN)

    def add_point(self, name: str, color: int, radius: float = 0.015, opacity: float = 0.6) -> None:
        """A sphere ``extras/<name>`` that :meth:`show` places with ``points={name: p}``."""
        self.vis[f"extras/{name}"].set_object(mg.Sphere(radius),
                                              mg.MeshLambertMaterial(color=color, opacity=opacity))

    def show(self, q: np.ndarray, stack=None, sim=None, t: float = 0.0, arrows: dict | None = None,
             points: dict | None = None) -> None:
        """Draw the state q (and, when given, the stack's targets and the simulator's
        contact forces, support polygon and active pushes). ``arrows``: {name: (start (m),
        direction, length (m)) or None to hide} and ``points``: {name: position (m)}, for
        the nodes made by :meth:`add_arrow` and :meth:`add_point`."""
        if self.anim is not None:
            with self.anim.at_frame(self.vis, self._frame) as frame:
                self._target = frame
                try:
                    self._draw(q, stack, sim, t, arrows, points)
                finally:
                    self._target = None
            self._frame += 1
        if self.live or self.anim is None:
            self._draw(q, stack, sim, t, arrows, points)

    def _draw(self, q, stack, sim, t, arrows=None, points=None) -> None:
        m, d = self.robot.model, self.viz.data
        pin.forwardKinematics(m, d, q)
        pin.updateGeometryPlacements(m, d, self.geom, self.viz.visual_data)
        for k, go in enumerate(self.geom.geometryObjects):   # mesh scales are baked in (_load_robot)
            self._place(self._node_name(go), self.viz.visual_data.oMg[k].homogeneous)
        com = pin.centerOfMass(m, d, q)
        self._node("overlay/com").set_transform(mt.translation_matrix(com))
        self._node("overlay/com_ground").set_transform(
            mt.translation_matrix([com[0], com[1], 0.001]) @ mt.rotation_matrix(np.pi / 2, [1, 0, 0]))
        if stack is not None:
            for task in stack:
                if isinstance(task, CoM) and task.target is not None:
                    self._node(f"targets/{task.name}").set_transform(mt.translation_matrix(task.target))
                elif isinstance(task, Frame) and task.target is not None:
                    self._node(f"targets/{task.name}").set_transform(task.target.homogeneous)
            self._legend = [line for task in stack if isinstance(task, Force)
                            for line in self._draw_task_force(task, stack)]
            for task in (t for t in stack if isinstance(t, CollisionAvoidance)):
                self._draw_witnesses(task)
        for name in self.frames:
            fid = self.robot.frame_id(name)
            pin.updateFramePlacement(m, d, fid)
            self._node(f"frames/{name}").set_transform(d.oMf[fid].homogeneous)
        if sim is not None:
            self._draw_contacts(sim, t)
        for name, arrow in (arrows or {}).items():
            if arrow is None:
                self._hide(f"extras/{name}")
            else:
                self._place(f"extras/{name}", *_arrow_pose(*arrow), hideable=True)
        for name, p in (points or {}).items():
            self._node(f"extras/{name}").set_transform(mt.translation_matrix(p))

    def _draw_witnesses(self, task) -> None:     # a collision task's witness segments (wbc.viz.collisions)
        if task.name not in self._witness_tasks:        # its slots' fixed objects, on first use
            self._witness_tasks.add(add_witness_nodes(self.vis, task))
        rec = self._target is not None      # a recording's set_property takes the value's type too
        draw_witness_slots(task, lambda p, T, s: self._place(p, T, s, hideable=True), self._hide,
                           lambda p, on: self._node(p).set_property("visible", *(("boolean", on) if rec else (on,))))

    def task_forces(self, task, stack) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """(point, desired, measured) of a force task at the last drawn state
        (:func:`wbc.viz.task_forces.task_forces`)."""
        return task_forces(self.robot, self.viz.data, task, stack)

    def _draw_task_force(self, task, stack) -> list[tuple[str, str]]:
        """Place a force task's two arrows (hidden below 1 mN); returns its legend lines."""
        if task.contact not in stack:
            return []
        point, desired, measured = self.task_forces(task, stack)
        lines = []
        for part, f in (("desired", desired), ("measured", measured)):
            path = f"task_forces/{task.name}/{part}"
            n = 0.0 if f is None else float(np.linalg.norm(f))
            if f is None or n < 1e-3:
                self._hide(path)
            else:
                self._place(path, *_arrow_pose(point, f, n / self.task_force_scale * 1e-3), hideable=True)
            shown = "—" if f is None else f"{n:7.3f} N"
            if part == "desired":
                lines.append((f"{task.name} λ_D {shown}  desired: teal sleeve, 1 cm per "
                              f"{self.task_force_scale * 10:g} N", part))
            else:
                lines.append((f"{task.name} λ_m {shown}  measured: pink core", part))
        return lines

    def _draw_contacts(self, sim, t) -> None:
        pts = sim.point_positions()
        for i, (p, f) in enumerate(zip(pts, sim.point_forces)):
            n = np.linalg.norm(f)
            if n < 1e-3:
                self._hide(f"forces/p{i}")
                continue
            self._place(f"forces/p{i}", *_arrow_pose(p, f, n / self.force_scale * 1e-3), hideable=True)
        loaded = pts[np.linalg.norm(sim.point_forces, axis=1) > 1e-3]
        if len(loaded) >= 3:
            from scipy.spatial import ConvexHull, QhullError

            try:
                hull = loaded[ConvexHull(loaded[:, :2]).vertices]
                line = np.vstack([hull, hull[:1]]).T + np.array([[0.0], [0.0], [0.002]])
                self.vis["overlay/support"].set_object(mg.Line(mg.PointsGeometry(line),
                                                               mg.LineBasicMaterial(color=COLORS["support"], linewidth=3)))
            except QhullError:  # degenerate hull (collinear points): keep the last polygon
                pass
        for k, p in enumerate(sim.pushes):
            if p.active(t):
                fid = sim.model.getFrameId(p.frame)
                pin.updateFramePlacement(sim.model, sim.data, fid)
                origin = sim.data.oMf[fid].translation
                n = np.linalg.norm(p.force)
                length = max(n / self.push_scale * 1e-3, PUSH_MIN_LENGTH)
                self._place(f"pushes/{k}", *_arrow_pose(origin - p.force / n * length, p.force, length),
                            hideable=True)
            else:
                self._hide(f"pushes/{k}")

    def init_contact_markers(self, sim) -> None:
        for i in range(len(sim.points)):
            self.vis[f"forces/p{i}"].set_object(mg.Cylinder(1.0, 0.006), mg.MeshLambertMaterial(color=COLORS["force"]))
        for k in range(len(sim.pushes)):
            self.vis[f"pushes/{k}"].set_object(mg.Cylinder(1.0, 0.012), mg.MeshLambertMaterial(color=COLORS["push"]))
            self.vis[f"pushes/{k}"].set_transform(HIDDEN)

    def show_diagnostics(self, sol, t: float, width: float = 1.3) -> None:
        """Show ``sol.diagnostics`` (see :mod:`wbc.viz.diagnostics`). Live: a table
        texture on a panel ``width`` units wide at 1 unit in front of the camera (the
        view is 2·tan(37.5°) ≈ 1.53 units high), top left of the view; its box, (x_left,
        y_top, width, height) in those units, is kept in ``hud_box``. Recording: kept
        for :meth:`save_html`."""
        if self.anim is not None:
            self._diag_frames.append(max(self._frame - 1, 0))
            self._diag_text.append(table_lines(sol, t, self._legend))
            if not self.live:
                return
        png, w, h = render_png(sol, t, extra=self._legend)
        height = width * h / w
        half_h = np.tan(HUD_FOV / 2)
        x0, y0 = -half_h * HUD_ASPECT + 0.02, half_h - 0.02
        self.hud_box = (x0, y0, width, height)
        material = mg.MeshBasicMaterial(map=mg.ImageTexture(mg.PngImage(png)), transparent=True, opacity=0.85, side=0,
                                        depthTest=False, depthWrite=False)
        node = self.vis[HUD_PATH]
        node.set_object(_OnTopMesh(mg.Box([width, height, 1e-4]), material))
        node.set_transform(mt.translation_matrix([x0 + width / 2, y0 - height / 2, -1.0]))

    def save_html(self, path: str | Path) -> Path:
        """Write a self-contained HTML page that replays the recorded run offline
        (with the priority diagnostics panel when :meth:`show_diagnostics` was fed)."""
        if self.anim is None:
            raise RuntimeError("Scene(record=True) is needed to save a recording")
        if self.hud_box is not None:      # the live panel: the replay has its own
            self.vis[HUD_PATH].delete()
            self.hud_box = None
        thin_animation(self.anim)       # the keys linear interpolation restores within 0.1 mm dropped
        self.vis.set_animation(self.anim, play=True, repetitions=1)
        html = self.vis.static_html()
        if self._diag_text:
            panel = overlay_html(self._diag_frames, self._diag_text, self.anim.default_framerate)
            i = html.rfind("</body>")
            html = html[:i] + panel + html[i:] if i >= 0 else html + panel
        path = Path(path)
        path.write_text(html)
        return path

    def close(self) -> None:
        """Stop this scene's Meshcat server process (and close its zmq socket)."""
        self.vis.window.zmq_socket.close(linger=0)
        if self.server is not None:
            server.stop(self.server)


def viewer_callback(scene: Scene, stack, dt: float, realtime: bool, speed: float = 1.0, fps: float = 30.0,
                    diagnostics_hz: float = 10.0, frames=()):
    """A :func:`wbc.runner.loop.run` callback drawing ``fps`` frames per simulated second,
    paced to ``speed`` × real time when ``realtime``, and the priority diagnostics
    ``diagnostics_hz`` times per simulated second (0: never). Between frames it
    only counts cycles. ``frames``: robot frames drawn with their actual axes
    (:meth:`Scene.set_targets`; :func:`shown_frames` gives a scenario's)."""
    import time

    every = max(1, round(1.0 / (fps * dt)))
    diag_every = max(1, round(fps / diagnostics_hz)) if diagnostics_hz > 0 else 0
    state = {"k": 0, "t0": None, "frames": 0}

    def cb(t, sim, sol):
        k = state["k"]
        state["k"] += 1
        if k == 0:
            scene.set_targets(stack, frames)
            scene.init_contact_markers(sim)
            state["t0"] = time.perf_counter()
        if k % every:
            return
        scene.show(sim.q, stack, sim, t)
        if diag_every and state["frames"] % diag_every == 0:
            scene.show_diagnostics(sol, t)
        state["frames"] += 1
        if realtime:
            lag = t / speed - (time.perf_counter() - state["t0"])
            if lag > 0:
                time.sleep(lag)

    return cb


def shown_frames(sc) -> tuple[str, ...]:
    """The robot frames a scenario's view draws with their actual axes: the glass's frame
    of an ``interaction:`` section (:mod:`wbc.interaction.external_force`), else none."""
    return (sc.interaction.glass_frame,) if sc.interaction is not None else ()
