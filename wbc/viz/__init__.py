"""Browser view (Meshcat): robot, targets, CoM and support polygon, contact forces, pushes,
priority diagnostics, force tasks' desired and measured forces, a glass's frame.

May import: :mod:`wbc.errors`, :mod:`wbc.sim`, :mod:`wbc.robot`, :mod:`wbc.tasks`. Not the runner.
"""

from .diagnostics import text_table
from .scene import Scene, shown_frames, viewer_callback

__all__ = ["Scene", "shown_frames", "text_table", "viewer_callback"]
