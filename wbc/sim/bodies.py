"""What a simulator touches and pushes: a robot's contact points (both simulators), a push,
small pinocchio models for simulator tests and demos (a free-floating box), and the joints-only
copy of a model the own simulator's dynamics calls take (:func:`dynamics_model`), the driver's torque
limits per dof (:func:`full_limits`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import WbcError


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


#: the model fields a joints-only copy keeps besides the joints, their placements and inertias
#: (what pinocchio's dynamics algorithms read: the armature in D = SᵀIS, the rest for completeness)
_JOINT_FIELDS = ("armature", "rotorInertia", "rotorGearRatio", "friction", "damping", "effortLimit",
                 "velocityLimit", "lowerPositionLimit", "upperPositionLimit")


#: the topology tables (index lists per joint) a joints-only copy leaves empty where the bindings copy the
#: model at every call: pinocchio's ABA and computeMinverse walk ``parents`` and the joints' own index
#: ranges, never these (read in pinocchio 3.8's algorithm/aba.hxx; its Data is built from ``parents``
#: alone for a model without mimic joints)
_TOPOLOGY_TABLES = ("children", "supports", "mimic_joint_supports", "subtrees")


def binding_copies_model() -> bool:
    """Whether this pinocchio's bindings of ``computeMinverse`` and ``aba`` copy the model at every
    call (pinocchio 3: their call policy ``mimic_not_supported_function`` takes it by value to look
    for mimic joints, bindings/python/utils/model-checker.hpp; pinocchio 4: no copy)."""
    return int(pin.__version__.split(".")[0]) == 3


def dynamics_model(model: pin.Model) -> pin.Model:
    """A copy of ``model`` with its joints (the same types, parents, placements, indices), their
    inertias, armature, limits and the gravity, and none of its frames; the joints named
    ``j1``, ``j2``, ... (short names: no heap allocation per name); ``model`` itself when it
    has a mimic joint.

    Why: pinocchio 3's bindings of ``computeMinverse`` and ``aba`` check for mimic joints
    with a copy of the model they are given, at every call (``mimic_not_supported_function``
    takes it by value): for Talos (34 joints, 121 frames with their names) that copy is ~30 µs
    of a ~45 µs call. The algorithms read only the joints, placements, inertias, armature and
    gravity, which this copy holds as they are, so M⁻¹ and ABA's accelerations are the same
    numbers, bit for bit (tests/sim/test_dynamics_model.py); pinocchio 4's bindings copy
    nothing, and the copy costs there what the full model costs. The copy is taken when the
    simulator is built: a model changed afterwards needs a new simulator (nothing in wbc changes
    a simulator's model after that; a perturbed model is given to the simulator it perturbs).

    Where the bindings copy the model (:func:`binding_copies_model`), the copy's topology tables
    (each joint's children, supports and subtree: ~4 allocations a joint, ~10 µs of Talos's ~14 µs
    copy on pinocchio 3.8) are left empty: the copy is then for ``computeMinverse``, ``aba`` and
    ``createData`` only, and no other algorithm may be called on it (a Jacobian or centre-of-mass
    algorithm reads these tables)."""
    if any("Mimic" in model.joints[j].shortname() for j in range(1, model.njoints)):
        return model
    out = pin.Model()
    out.name = model.name
    for j in range(1, model.njoints):
        out.addJoint(int(model.parents[j]), model.joints[j], model.jointPlacements[j], f"j{j}")
        out.inertias[j] = model.inertias[j].copy()
    for name in _JOINT_FIELDS:
        if hasattr(model, name):
            setattr(out, name, getattr(model, name).copy())
    out.gravity = model.gravity.copy()
    if binding_copies_model():
        for name in _TOPOLOGY_TABLES:
            if hasattr(out, name):
                del getattr(out, name)[:]
    return out


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


def full_limits(tau_limits, actuated: np.ndarray) -> np.ndarray | None:
    """The driver's torque limits ``tau_limits`` (na or nv, N·m; None: none) as an nv vector,
    inf on the unactuated dofs of the mask ``actuated`` (nv bool); WbcError on another size or
    a negative or NaN limit."""
    if tau_limits is None:
        return None
    lim = np.asarray(tau_limits, dtype=float).ravel()
    nv, na = actuated.shape[0], int(actuated.sum())
    full = np.full(nv, np.inf)
    if lim.shape[0] == nv:
        full[actuated] = lim[actuated]
    elif lim.shape[0] == na:
        full[actuated] = lim
    else:
        raise WbcError(f"simulator: tau_limits has {lim.shape[0]} entries, expected {na} (actuated) "
                       f"or {nv} (dofs)")
    if np.any(np.isnan(full)) or np.any(full < 0.0):
        raise WbcError("simulator: tau_limits must be >= 0 (inf for no limit)")
    return full
