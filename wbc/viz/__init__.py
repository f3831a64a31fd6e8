"""Browser views: the live page you act in (viser: :mod:`~wbc.viz.live` hands the state to a drawing
process, :mod:`~wbc.viz.drawing`, through shared memory; :mod:`~wbc.viz.controls` holds the gizmos,
sliders, buttons and plots, :mod:`~wbc.viz.overlays` the run's overlays) and offline replays (Meshcat:
:class:`Scene`): robot, targets, CoM and support polygon, contact forces, pushes, priority
diagnostics, force tasks' desired and measured forces, a glass's frame. docs/viewer.md.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.sim`, :mod:`wbc.robot`, :mod:`wbc.tasks`,
:mod:`wbc.jsonable` (messages between its processes). Not the runner.
"""

from .diagnostics import text_table
from .scene import Scene, shown_frames, viewer_callback

__all__ = ["Scene", "shown_frames", "text_table", "viewer_callback"]
