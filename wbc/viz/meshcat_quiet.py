"""meshcat 0.3.2 (and pinocchio's visualizer on it), imported in one place with its import-time
DeprecationWarning silenced: meshcat's package imports its server module, which imports
``zmq.eventloop.ioloop`` (pyzmq warns at that import: deprecated since pyzmq 17). Nothing of it
is called by the package. Every module of :mod:`wbc.viz` takes meshcat from here, but the
Meshcat server's script (:mod:`wbc.viz.server`, run by its path, outside the package), which
silences the same warning at its own import."""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", "zmq.eventloop.ioloop is deprecated", DeprecationWarning)
    import meshcat
    import meshcat.geometry as mg
    import meshcat.transformations as mt
    from meshcat.animation import Animation
    from pinocchio.visualize import MeshcatVisualizer

__all__ = ["Animation", "MeshcatVisualizer", "meshcat", "mg", "mt"]
