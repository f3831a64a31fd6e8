"""What the chapter-controller demos share: their command line (``--viz``,
``--headless``, ``--record``) and a browser view of the Panda with a surface plate,
target markers and force arrows, live or recorded to HTML.

Live (``--viz`` or a display): the viser page of ``wbc run`` (:class:`wbc.viz.live.LiveView`,
drawn by a process of its own; the plate a surface, the arrows and targets its overlays) on
127.0.0.1, paced to real time. Otherwise every drawn frame goes into a Meshcat scene's
animation (:class:`wbc.viz.Scene`) and :meth:`finish` writes a self-contained HTML replay.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from types import SimpleNamespace

import meshcat.geometry as mg
import meshcat.transformations as mt
import numpy as np
import pinocchio as pin

from wbc.viz import Scene

ROOT = Path(__file__).resolve().parent.parent
COLORS = {"contact": 0xF39C12, "push": 0x8E44AD, "target": 0x2E86DE, "surface": 0x8D6E63}


def demo_args(doc: str, name: str, parser: argparse.ArgumentParser | None = None):
    """Parse a chapter demo's command line (``parser``: one with the demo's own options
    already added); returns (args, live): live in the browser with ``--viz`` or a display,
    else headless with an HTML replay at ``--record`` (default recordings/<name>.html)."""
    parser = parser or argparse.ArgumentParser(description=doc.split("\n")[0])
    parser.add_argument("--viz", action="store_true", help="play live in the browser (viser)")
    parser.add_argument("--headless", action="store_true", help="never open a browser; record HTML")
    parser.add_argument("--record", default=str(ROOT / "recordings" / f"{name}.html"),
                        help="where the headless run writes its HTML replay")
    args = parser.parse_args()
    return args, not args.headless and (args.viz or bool(os.environ.get("DISPLAY")))


class ArmView:
    """``arrows``: {name: kind ("contact" or "push")}; ``targets``: marker names;
    ``m_per_newton``: arrow length per newton."""

    def __init__(self, robot, live: bool, arrows: dict[str, str] = (), targets=(), m_per_newton: float = 0.01,
                 fps: float = 30.0) -> None:
        self.live, self.robot, self.fps = live, robot, fps
        self.scale = m_per_newton
        self.every = 1.0 / fps
        self._next = 0.0
        self._wall0 = None
        self.kinds = dict(arrows)
        self.surfaces: list = []        # live: the plates, drawn once the view starts (first frame)
        self.view = None
        self.scene = None if live else Scene(robot, [], record=True)
        if live:
            return
        self.vis = self.scene.vis
        for name, kind in self.kinds.items():
            self.scene.add_arrow(name, COLORS[kind], 0.008 if kind == "contact" else 0.012)
        for name in targets:
            self.scene.add_point(f"target_{name}", COLORS["target"])
        # camera: 1.6 m from the arm's workspace, slightly above (meshcat's default is far away)
        self.vis["/Cameras/default"].set_transform(mt.translation_matrix([0.3, 0.0, 0.4]))
        self.vis["/Cameras/default/rotated/<object>"].set_property("position", [1.0, 0.9, 1.0])

    def plate(self, point, normal, size=(0.6, 0.6)) -> None:
        """A thin plate showing a plane surface (top face through ``point``)."""
        n = np.asarray(normal, float) / np.linalg.norm(normal)
        if self.live:
            from wbc.sim.environment import Box, HalfSpace

            vertical = np.allclose(n, [0.0, 0.0, 1.0])
            self.surfaces.append(Box(np.asarray(point, float) - 0.005 * n, np.array([*size, 0.01]), name="surface")
                                 if vertical else HalfSpace(np.asarray(point, float), n, name="surface"))
            return
        T = np.eye(4)
        z = np.array([0.0, 0.0, 1.0])
        axis = np.cross(z, n)
        if np.linalg.norm(axis) > 1e-9:
            T[:3, :3] = pin.exp3(axis / np.linalg.norm(axis) * np.arccos(np.clip(z @ n, -1, 1)))
        T[:3, 3] = np.asarray(point, float) - 0.005 * n
        self.vis["extras/surface"].set_object(mg.Box([size[0], size[1], 0.01]),
                                                   mg.MeshLambertMaterial(color=COLORS["surface"], opacity=0.85))
        self.vis["extras/surface"].set_transform(T)

    def due(self, t: float) -> bool:
        return t + 1e-9 >= self._next

    def draw(self, q, t: float, arrows: dict | None = None, targets: dict | None = None) -> None:
        """Draw one frame: the robot at q, each arrow (point (m), force (N), world: a push
        arrow ends at its point of application, a contact-force arrow starts there),
        each target position."""
        if not self.due(t):
            return
        self._next = t + self.every
        shown = {}
        for name, (p, f) in (arrows or {}).items():
            n = np.linalg.norm(f)
            length = n * self.scale
            if n < 1e-3:
                shown[name] = None
            else:
                start = p if self.kinds[name] == "contact" else p - f / n * length
                shown[name] = (start, f, length)
        points = {f"target_{k}": p for k, p in (targets or {}).items()}
        if not self.live:
            self.scene.show(q, arrows=shown, points=points)
            return
        self._publish(q, t, shown, points)
        if self._wall0 is None:
            self._wall0 = time.perf_counter() - t
        lag = t - (time.perf_counter() - self._wall0)
        if lag > 0:
            time.sleep(lag)

    def _publish(self, q, t: float, shown: dict, points: dict) -> None:
        """Hand a frame to the live view (started at the first frame, once the plates are known)."""
        from wbc.viz.live import LiveView

        if self.view is None:
            self.view = LiveView(self.robot, self.surfaces, fps=self.fps, overlays={"forces": True, "targets": True},
                                 camera=((1.3, 0.9, 1.4), (0.3, 0.0, 0.4)))   # the arm's workspace, from above
            print(f"browser view: {self.view.url}")
        segs = [(a[0], a[0] + a[1] / np.linalg.norm(a[1]) * a[2]) for a in shown.values() if a is not None]
        colors = [_rgb(COLORS[self.kinds[name]]) for name, a in shown.items() if a is not None]
        overlays = {"forces": {"arrows": np.array(segs).reshape(-1, 2, 3), "colors": np.array(colors).reshape(-1, 3)},
                    "targets": {"points": np.array(list(points.values())).reshape(-1, 3),
                                "colors": np.tile(_rgb(COLORS["target"]), (len(points), 1))}}
        none = np.zeros((0, 3))
        self.view.publish(SimpleNamespace(t=t, q=np.array(q, float), points=none, forces=none, pushes=[], targets={},
                                          sol=None, normal={}, levels=[], disabled=[], paused=False, speed=1.0,
                                          rtf=0.0, done=False, overlays=overlays))

    def finish(self, path: str | Path) -> None:
        if self.live:
            if self.view is not None:
                self.view.close()
            return
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        print(f"replay written to {self.scene.save_html(path)} (open it in a browser; works offline)")
        self.scene.close()


def _rgb(color: int) -> tuple[int, int, int]:
    return (color >> 16) & 255, (color >> 8) & 255, color & 255
