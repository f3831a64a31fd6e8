"""The glass-of-water figures of an interaction run (5.3.5), on the simulator's true state.

- ``glass_tilt_max`` (rad): the largest angle between the glass's axis and the vertical.
  The glass is held level at the start: its axis is the glass frame's direction that is
  vertical then, u = R₀ᵀ e_z in the frame; tilt(t) = arccos(e_zᵀ R(t) u).
- ``hand_position_error_max`` (m): the largest ‖p(t) − p_d(t)‖ of the glass frame's origin
  against the target of its frame task at that cycle.
- ``elbow_displacement_max`` (m): the largest displacement of the pushed frame (the elbow)
  from where it was when the first push began, in the frame ``base`` (the robot's own
  body: a driving base carries the arm along, and that is not the push's doing).
- ``push_displacement`` (m): the elbow's displacement at the end of the first push.

The state is the simulator's (``sim.q`` on its model), not the controller's measurement.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin


class GlassMetrics:
    """Accumulates the figures of the module docstring, one :meth:`record` per cycle.

    ``model``: the simulated robot's pinocchio model; ``glass``, ``elbow``, ``base``: URDF frame
    names; ``push_window``: (start, end) s of the first push, or None (then the elbow's
    reference is its position at the first record)."""

    def __init__(self, model: pin.Model, glass: str, elbow: str, base: str,
                 push_window: tuple[float, float] | None) -> None:
        self.model, self.data = model, model.createData()
        self.fg, self.fe, self.fb = (model.getFrameId(f) for f in (glass, elbow, base))
        self.window = push_window
        self.axis: np.ndarray | None = None          # the glass's axis in its frame
        self.elbow0: np.ndarray | None = None        # the elbow in the base frame at the push's start
        self.tilt_max = self.error_max = self.elbow_max = 0.0
        self.elbow_at_end: float | None = None

    def record(self, t: float, q: np.ndarray, target: pin.SE3 | None) -> None:
        """One cycle at time t (s), true configuration q, the glass task's target (world)."""
        m, d = self.model, self.data
        pin.framesForwardKinematics(m, d, q)
        G = d.oMf[self.fg]
        if self.axis is None:
            self.axis = G.rotation.T @ np.array([0.0, 0.0, 1.0])
        cz = float(G.rotation[2] @ self.axis)
        self.tilt_max = max(self.tilt_max, math.acos(min(1.0, max(-1.0, cz))))
        if target is not None:
            self.error_max = max(self.error_max, float(np.linalg.norm(G.translation - target.translation)))
        if self.window is None or t >= self.window[0] - 1e-9:
            p = d.oMf[self.fb].actInv(d.oMf[self.fe].translation)
            if self.elbow0 is None:
                self.elbow0 = p.copy()
            moved = float(np.linalg.norm(p - self.elbow0))
            self.elbow_max = max(self.elbow_max, moved)
            if self.window is not None and self.elbow_at_end is None and t >= self.window[1] - 1e-9:
                self.elbow_at_end = moved

    def summary(self) -> dict:
        out = {"glass_tilt_max": self.tilt_max, "hand_position_error_max": self.error_max,
               "elbow_displacement_max": self.elbow_max}
        if self.elbow_at_end is not None:
            out["push_displacement"] = self.elbow_at_end
        return out
