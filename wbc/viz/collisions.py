"""The collision task's witness segments in the browser view (:class:`wbc.viz.scene.Scene`)."""

from __future__ import annotations

import meshcat.geometry as mg
import numpy as np


def witness_color(d: float, safety: float, influence: float) -> int:
    """0xRRGG00 for a distance d (m): red at or below the safety distance, yellow half way,
    green at the influence distance."""
    u = float(np.clip((d - safety) / (influence - safety), 0.0, 1.0))
    r, g = (1.0, 2 * u) if u < 0.5 else (2 * (1 - u), 1.0)
    return (int(255 * r) << 16) | (int(255 * min(g, 1.0)) << 8)


def draw_witnesses(vis, task, count: int = 5) -> None:
    """The ``count`` closest pairs' witness segments p₁–p₂ of a collision task's last cycle
    (:attr:`wbc.tasks.CollisionAvoidance.last`), coloured by distance (:func:`witness_color`),
    under ``collision/<task>/<slot>`` of the meshcat visualizer ``vis``; pairs beyond the
    influence distance have no row and are not drawn. Live only: a recording's frames hold
    transforms, not new lines."""
    last = task.last
    rows, order = (None, []) if last is None else last
    for slot in range(count):
        node = vis[f"collision/{task.name}/{slot}"]
        if slot >= len(order):
            node.delete()
            continue
        i = order[slot]
        line = np.stack([rows.p1[i], rows.p2[i]], axis=1).astype(np.float32)
        node.set_object(mg.Line(mg.PointsGeometry(line), mg.LineBasicMaterial(
            color=witness_color(float(rows.d[i]), task.safety, task.influence), linewidth=4)))
