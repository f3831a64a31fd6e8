"""Browser view (Meshcat): robot, targets, CoM and support polygon, contact forces, pushes,
priority diagnostics."""

from .diagnostics import text_table
from .scene import Scene, viewer_callback

__all__ = ["Scene", "text_table", "viewer_callback"]
