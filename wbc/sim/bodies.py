"""Small pinocchio models for simulator tests and demos (a free-floating box)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def box_model(size=(0.2, 0.2, 0.2), mass: float = 5.0) -> tuple[pin.Model, list[tuple[str, np.ndarray]]]:
    """A free-flying box (sizes in m, mass in kg) and its 8 corners as contact points
    ``(joint name, position in the joint frame)``."""
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "box")
    sx, sy, sz = size
    inertia = pin.Inertia(mass, np.zeros(3), mass / 12.0 * np.diag([sy**2 + sz**2, sx**2 + sz**2, sx**2 + sy**2]))
    m.appendBodyToJoint(j, inertia, pin.SE3.Identity())
    m.addFrame(pin.Frame("box", j, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    corners = [("box", 0.5 * np.array([x * sx, y * sy, z * sz])) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    return m, corners
