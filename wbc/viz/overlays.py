"""The run's own overlays in the live view (drawing process): what a scenario has beyond the robot,
its contacts and its CoM, each with a checkbox of its own in the page's **Overlays** folder.

The control process gathers them (:func:`wbc.runner.interactive.overlay_data`) as plain arrays
under a name, and :class:`Overlays` draws each name with one primitive:

- ``"segments"``: (n, 2, 3) m and ``"colors"`` (n, 3) RGB 0-255: line segments (the collision
  task's closest pairs' witness segments p₁–p₂, red at the safety distance, green at the
  influence distance; a walking run's support polygon);
- ``"arrows"``: (n, 2, 3) m and ``"colors"`` (n, 3): arrows from start to end (a force task's
  desired λ_D and measured λ_m);
- ``"points"``: (n, 3) m and ``"colors"`` (n, 3): dots (planned ZMP and DCM, centre of pressure);
- ``"segments"`` also draws a walk's planned footsteps.

The names a run has (``spec["overlays"]``, {name: default on}) are known when the view starts.
"""

from __future__ import annotations

from typing import Any

import numpy as np

POINT_SIZE = 0.03           # m: a dot's diameter


class Overlays:
    """The run's overlays of a :class:`~wbc.viz.drawing.Drawer` (registered in its ``overlays``
    switches)."""

    def __init__(self, drawer) -> None:
        self.drawer = drawer
        self.handles: dict[str, Any] = {}
        for name, on in drawer.spec.get("overlays", {}).items():
            drawer.overlays[name] = bool(on)

    def draw(self, snap) -> None:
        """Draw each overlay of ``snap.overlays`` (hide those switched off or absent)."""
        data = getattr(snap, "overlays", None) or {}
        for name in set(self.handles) | set(data):
            item = data.get(name) or {}
            path = "/overlay/run/" + name.replace(" ", "_")
            key = next((k for k in ("arrows", "segments", "points") if k in item), None)
            shown = self.drawer.overlays.get(name, True) and key is not None and len(item[key]) > 0
            h = self.handles.get(name)
            if key == "arrows" or h == "arrows":
                self.drawer.set_arrows(path, list(item["arrows"]) if shown else [], item.get("colors"), 0.005, 0.012)
                self.handles[name] = "arrows"
            elif not shown:
                if h is not None:
                    h.visible = False
            else:
                self.handles[name] = self._place(path, h, item)

    def _place(self, path: str, h, item: dict):
        sc = self.drawer.server.scene
        if "segments" in item:
            pts = np.asarray(item["segments"], np.float32)
            colors = np.repeat(np.asarray(item["colors"], np.uint8)[:, None, :], 2, axis=1)
            if h is not None and h.points.shape == pts.shape:
                h.points, h.colors, h.visible = pts, colors, True
                return h
            if h is not None:
                h.remove()
            return sc.add_line_segments(path, pts, colors, thickness=4.0)
        pts = np.asarray(item["points"], np.float32).reshape(-1, 3)
        colors = np.asarray(item["colors"], np.uint8).reshape(-1, 3)
        if h is not None and h.points.shape == pts.shape:
            h.points, h.colors, h.visible = pts, colors, True
            return h
        if h is not None:
            h.remove()
        return sc.add_point_cloud(path, pts, colors, point_size=POINT_SIZE, point_shape="circle")
