"""meshcat 0.3.2 (and pinocchio's visualizer on it), imported in one place with its import-time
DeprecationWarning silenced: meshcat's package imports its server module, which imports
``zmq.eventloop.ioloop`` (pyzmq warns at that import: deprecated since pyzmq 17). Nothing of it
is called by the package. Every module of :mod:`wbc.viz` takes meshcat from here."""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", "zmq.eventloop.ioloop is deprecated", DeprecationWarning)
    import meshcat
    import meshcat.geometry as mg
    import meshcat.transformations as mt
    from meshcat.animation import Animation
    from meshcat.servers.zmqserver import ZMQWebSocketBridge
    from pinocchio.visualize import MeshcatVisualizer

__all__ = ["Animation", "MeshcatVisualizer", "ZMQWebSocketBridge", "meshcat", "mg", "mt"]
