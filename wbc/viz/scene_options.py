"""How a :class:`wbc.viz.scene.Scene` draws and records: its option record."""

from __future__ import annotations

from dataclasses import dataclass

from ..options import Options

#: m: the robot meshes' clustering grid (wbc.viz.meshes.cluster)
MESH_CELL = 0.005


@dataclass(frozen=True)
class SceneOptions(Options):
    """How a :class:`Scene` draws and records."""

    record: bool = False
    """keep an animation of the drawn frames (:meth:`Scene.save_html`)"""
    live: bool | None = None
    """also draw on the server's page while recording; None: only without ``record``"""
    fps: float = 30.0
    """frame rate of a recording's animation, 1/s (match :func:`viewer_callback`'s)"""
    force_scale: float = 2.0
    """N per mm of contact-force arrow (1 mm per 2 N)"""
    push_scale: float = 0.5
    """N per mm of push arrow (2 mm per N)"""
    task_force_scale: float = 0.1
    """N per mm of a force task's arrows (1 cm per N)"""
    mesh_cell: float = MESH_CELL
    """grid cell the visual meshes are thinned on, m (:mod:`wbc.viz.meshes`)"""
