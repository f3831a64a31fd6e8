"""Browser view (Meshcat): robot, targets, CoM and support polygon, contact forces, pushes."""

from .scene import Scene, viewer_callback

__all__ = ["Scene", "viewer_callback"]
