"""What a simulator touches and pushes: a robot's contact points (both simulators), a push, and
small pinocchio models for simulator tests and demos (a free-floating box)."""

from __future__ import annotations

from dataclasses import dataclass

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


def contact_points(robot, extra_points=()) -> list[tuple[str, np.ndarray, str, np.ndarray, str]]:
    """The points where ``robot`` (a :class:`~wbc.robot.model.RobotModel`) touches the environment,
    for every simulator: the four corners of each contact surface (± half_length, ± half_width
    in the sole frame, m), the origin of each point contact, and ``extra_points`` (frame name,
    offset in the frame, m). Each as (joint name, offset in the joint frame (m), kind
    ("surface" or "point"), rotation of the point's frame in the joint frame, contact name)."""
    m = robot.model
    pts = []
    for c in robot.contacts.values():
        f = m.frames[m.getFrameId(c.frame)]
        offs = ([np.array([sx * c.half_length, sy * c.half_width, 0.0]) for sx in (-1, 1) for sy in (-1, 1)]
                if c.kind == "surface" else [np.zeros(3)])
        pts += [(m.names[f.parentJoint], f.placement.act(o), c.kind, f.placement.rotation, c.name) for o in offs]
    for fname, off in extra_points:
        f = m.frames[robot.frame_id(fname)]
        pts.append((m.names[f.parentJoint], f.placement.act(np.asarray(off, float)), "point",
                    f.placement.rotation, fname))
    return pts


@dataclass
class Push:
    """A constant external force (N, world frame) at a frame's origin during [start, start + duration)."""

    frame: str
    force: np.ndarray
    start: float
    duration: float

    def active(self, t: float) -> bool:
        return self.start <= t < self.start + self.duration
