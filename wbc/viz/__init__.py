"""Browser view (Meshcat): robot, targets, CoM and support polygon, contact forces, pushes,
priority diagnostics, force tasks' desired and measured forces, a glass's frame."""

from .diagnostics import text_table
from .scene import Scene, shown_frames, viewer_callback

__all__ = ["Scene", "shown_frames", "text_table", "viewer_callback"]
