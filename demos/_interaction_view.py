"""Browser view shared by the force/interaction demos: the Panda (wbc.viz.Scene),
a surface plate, target markers and force arrows, live or recorded to HTML.

Live (``--viz`` or a display): a Meshcat page on 127.0.0.1, paced to real time.
Otherwise every drawn frame goes into the scene's animation and :meth:`finish`
writes a self-contained HTML replay.
"""

from __future__ import annotations

import time
from pathlib import Path

import meshcat.geometry as mg
import meshcat.transformations as mt
import numpy as np
import pinocchio as pin

from wbc.viz import Scene

HIDDEN = np.diag([1e-6, 1e-6, 1e-6, 1.0])
COLORS = {"contact": 0xF39C12, "push": 0x8E44AD, "target": 0x2E86DE, "surface": 0x8D6E63}


def arrow_pose(origin: np.ndarray, vec: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """(rigid transform, scale) taking meshcat's unit cylinder (axis y, centred at 0) onto
    the segment origin → origin + length·vec/|vec|: scale (1, length, 1) along the axis."""
    d = vec / max(np.linalg.norm(vec), 1e-12)
    y = np.array([0.0, 1.0, 0.0])
    axis, c = np.cross(y, d), float(y @ d)
    s = np.linalg.norm(axis)
    if s < 1e-9:
        R = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        R = pin.exp3(axis / s * np.arctan2(s, c))
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = origin + 0.5 * length * d
    return T, np.array([1.0, length, 1.0])


class InteractionView:
    """``arrows``: {name: kind ("contact" or "push")}; ``targets``: marker names;
    ``m_per_newton``: arrow length per newton."""

    def __init__(self, robot, live: bool, arrows: dict[str, str] = (), targets=(), m_per_newton: float = 0.01,
                 fps: float = 30.0) -> None:
        self.live = live
        self.scene = Scene(robot, [], open_browser=live, record=not live)
        self.vis = self.scene.vis
        self.scale = m_per_newton
        self.every = 1.0 / fps
        self._next = 0.0
        self._wall0 = None
        self._frame = 0
        self.kinds = dict(arrows)
        for name, kind in dict(arrows).items():
            self.vis[f"interaction/{name}"].set_object(mg.Cylinder(1.0, 0.008 if kind == "contact" else 0.012),
                                                       mg.MeshLambertMaterial(color=COLORS[kind]))
            self.vis[f"interaction/{name}"].set_transform(HIDDEN)
        for name in targets:
            self.vis[f"interaction/target_{name}"].set_object(mg.Sphere(0.015), mg.MeshLambertMaterial(
                color=COLORS["target"], opacity=0.6))
        # camera: 1.6 m from the arm's workspace, slightly above (meshcat's default is far away)
        self.vis["/Cameras/default"].set_transform(mt.translation_matrix([0.3, 0.0, 0.4]))
        self.vis["/Cameras/default/rotated/<object>"].set_property("position", [1.0, 0.9, 1.0])
        if live:
            print(f"browser view: {self.scene.url}")

    def plate(self, point, normal, size=(0.6, 0.6)) -> None:
        """A thin plate showing a plane surface (top face through ``point``)."""
        n = np.asarray(normal, float) / np.linalg.norm(normal)
        T = np.eye(4)
        z = np.array([0.0, 0.0, 1.0])
        axis = np.cross(z, n)
        if np.linalg.norm(axis) > 1e-9:
            T[:3, :3] = pin.exp3(axis / np.linalg.norm(axis) * np.arccos(np.clip(z @ n, -1, 1)))
        T[:3, 3] = np.asarray(point, float) - 0.005 * n
        self.vis["interaction/surface"].set_object(mg.Box([size[0], size[1], 0.01]),
                                                   mg.MeshLambertMaterial(color=COLORS["surface"], opacity=0.85))
        self.vis["interaction/surface"].set_transform(T)

    def due(self, t: float) -> bool:
        return t + 1e-9 >= self._next

    def draw(self, q, t: float, arrows: dict | None = None, targets: dict | None = None) -> None:
        """Draw one frame: the robot at q, each arrow (point (m), force (N), world: a push
        arrow ends at its point of application, a contact-force arrow starts there),
        each target position."""
        if not self.due(t):
            return
        self._next = t + self.every
        self.scene.show(q)
        node = self.vis if self.scene.anim is None else self.scene.anim.at_frame(self.vis, self._frame)
        self._frame += 1
        for name, (p, f) in (arrows or {}).items():
            n = np.linalg.norm(f)
            length = n * self.scale
            if n < 1e-3:
                T, scale = np.eye(4), np.full(3, 1e-6)
            else:
                start = p if self.kinds[name] == "contact" else p - f / n * length
                T, scale = arrow_pose(start, f, length)
            self._set(node[f"interaction/{name}"], T, scale)
        for name, p in (targets or {}).items():
            node[f"interaction/target_{name}"].set_transform(mt.translation_matrix(p))
        if self.live:
            if self._wall0 is None:
                self._wall0 = time.perf_counter() - t
            lag = t - (time.perf_counter() - self._wall0)
            if lag > 0:
                time.sleep(lag)

    def _set(self, node, T: np.ndarray, scale: np.ndarray) -> None:
        """Place a node with a scale. Live: one matrix. Recording: meshcat's animation keeps
        position and quaternion only, so the scale goes in its own ``scale`` track."""
        if self.scene.anim is None:
            node.set_transform(T @ np.diag([*scale, 1.0]))
        else:
            node.set_transform(T)
            node.set_property("scale", "vector3", [float(x) for x in scale])

    def finish(self, path: str | Path) -> None:
        if not self.live:
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            print(f"replay written to {self.scene.save_html(path)} (open it in a browser; works offline)")
        self.scene.close()
