"""Robot-YAML features beyond a URDF: offset frames, point contacts with a radius,
continuous joints, levelling on the contacts, load-time warnings.

Offset frames (``frames: {alias: {link: NAME, xyz: [x, y, z], rpy: [r, p, y]}}``)
    an operational frame named ``alias`` added to the pinocchio model, fixed to the URDF
    frame ``link`` at placement ^link M_alias = (R(rpy), xyz): xyz in m in ``link``'s
    axes, rpy in rad (pinocchio's roll-pitch-yaw, R = R_z(y) R_y(p) R_x(r)).

Point contacts with ``radius`` (m) and ``offset`` ([x, y, z] m in the frame's axes)
    the foot is a sphere of radius r centred at c = (frame origin + offset). On flat
    ground the touching point is the sphere's bottom, c − r e_z (e_z the world vertical,
    the ground normal). The model fixes that point to the link at the *default posture*:
    with ^0R_f the frame's world rotation there, the contact point is the frame
    ``<contact>_point`` at ^f p = offset − r ^0R_fᵀ e_z, oriented like the world there
    (its z axis points up at the default posture). A sphere that rolls (the leg pitching by
    θ) moves its true touching point by r θ along the ground: the model ignores that
    (2.2 cm × 0.1 rad = 2 mm for the Go2), as it ignores the rolling in the simulator.

Continuous joints (nq = 2, (cos θ, sin θ)) take an angle θ (rad) wherever the YAML gives a
joint value (:func:`set_joint_value`).

:class:`RobotWarning` (``warnings.warn``) is issued by :func:`check_robot` at load time,
naming the joint or contact: the static torque at the default posture above a torque limit
(:func:`static_torques`), a default posture outside the position limits, a contact frame
whose z axis is more than 15° from the vertical at the default posture.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.errors import RobotDefinitionError, RobotWarning
from wbc.validation.schema import mapping, number, text, vector

#: a contact frame's z axis may lean this far from the vertical (rad) without a warning
CONTACT_TILT_WARN = math.radians(15.0)


# ----------------------------------------------------------------- schema pieces
def frame_entry(value: Any, key: str) -> str | dict:
    """``frames.<alias>``: a URDF frame name, or ``{link: NAME, xyz: [3] m, rpy: [3] rad}``."""
    if isinstance(value, dict):
        spec = mapping(value, key, allowed={"link", "xyz", "rpy"}, required=("link",), error=RobotDefinitionError)
        return {"link": text(spec["link"], f"{key}.link", what="a URDF link or frame name", error=RobotDefinitionError),
                "xyz": vector(spec.get("xyz", [0.0, 0.0, 0.0]), f"{key}.xyz", 3, ge=-10, le=10, unit="m",
                              error=RobotDefinitionError),
                "rpy": vector(spec.get("rpy", [0.0, 0.0, 0.0]), f"{key}.rpy", 3, ge=-2 * math.pi, le=2 * math.pi,
                              unit="rad", error=RobotDefinitionError)}
    return text(value, key, what="a URDF frame name or {link: NAME, xyz: [x, y, z], rpy: [r, p, y]}", error=RobotDefinitionError)


def contact_extras(spec: dict, key: str) -> dict:
    """``radius`` (m, in [0, 0.5]) and ``offset`` ([3] m) of a point contact."""
    out: dict = {}
    if "radius" in spec:
        out["radius"] = number(spec["radius"], f"{key}.radius", ge=0, le=0.5, unit="m", error=RobotDefinitionError)
    if "offset" in spec:
        out["offset"] = vector(spec["offset"], f"{key}.offset", 3, ge=-1, le=1, unit="m", error=RobotDefinitionError)
    if out and spec.get("kind", "surface") != "point":
        raise RobotDefinitionError("radius and offset are for a point contact (kind: point)", key=f"{key}.{next(iter(out))}")
    return out


# ----------------------------------------------------------------- model edits
def add_frame(model: pin.Model, name: str, parent: str, placement: pin.SE3, key: str) -> None:
    """Add operational frame ``name`` at ``placement`` relative to frame ``parent``."""
    if not model.existFrame(parent):
        from wbc.validation.schema import suggest

        raise RobotDefinitionError(f"the URDF has no link or frame '{parent}'{suggest(parent, [f.name for f in model.frames])}",
                                   key=key)
    if model.existFrame(name):
        raise RobotDefinitionError(f"the URDF already has a frame '{name}'; give the offset frame another alias", key=key)
    pf = model.frames[model.getFrameId(parent)]
    model.addFrame(pin.Frame(name, pf.parentJoint, model.getFrameId(parent), pf.placement * placement,
                             pin.FrameType.OP_FRAME))


def add_offset_frames(model: pin.Model, frames: dict) -> dict[str, str]:
    """Add the ``{link, xyz, rpy}`` frames of ``frames`` (alias -> name or spec) to ``model``;
    returns alias -> frame name (the alias itself for an offset frame)."""
    out = {}
    for alias, spec in frames.items():
        if isinstance(spec, dict):
            add_frame(model, alias, spec["link"], pin.SE3(pin.rpy.rpyToMatrix(*spec["rpy"]), spec["xyz"]),
                      f"frames.{alias}.link")
            out[alias] = alias
        else:
            out[alias] = spec
    return out


def set_joint_value(model: pin.Model, q: np.ndarray, jid: int, value: float) -> None:
    """Write joint ``jid``'s value into ``q``: θ (rad) or d (m) for a 1-coordinate joint,
    (cos θ, sin θ) for a continuous (nq = 2) joint given its angle θ (rad)."""
    i, nq = model.idx_qs[jid], model.joints[jid].nq
    if nq == 1:
        q[i] = value
    elif nq == 2:
        q[i], q[i + 1] = math.cos(value), math.sin(value)
    else:
        raise RobotDefinitionError(f"joint '{model.names[jid]}' has {nq} coordinates; a joint value is for a revolute, prismatic "
                "or continuous joint")


def set_base_position(q: np.ndarray, root: str, base) -> None:
    """``base_position``: free flyer [x, y] or [x, y, z] (m; the orientation stays the
    posture's); planar [x, y] (m) or [x, y, yaw] (m, m, rad: written as (cos, sin))."""
    base = np.asarray(base, float)
    if root == "planar":
        q[:2] = base[:2]
        if len(base) == 3:
            q[2], q[3] = math.cos(base[2]), math.sin(base[2])
    else:
        q[: len(base)] = base


def point_contact_frame(model: pin.Model, q: np.ndarray, name: str, frame: str, radius: float,
                        offset: np.ndarray | None) -> str:
    """The frame of a point contact's touching point (module docstring): ``frame`` itself
    when there is no radius and no offset, else a new frame ``<name>_point``."""
    if not radius and (offset is None or not np.any(offset)):
        return frame
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    R = data.oMf[model.getFrameId(frame)].rotation
    p = (np.zeros(3) if offset is None else np.asarray(offset, float)) - radius * R.T @ np.array([0.0, 0.0, 1.0])
    new = f"{name}_point"
    add_frame(model, new, frame, pin.SE3(R.T, p), f"contacts.{name}")
    return new


def level_on_contacts(model: pin.Model, q: np.ndarray, contacts: dict) -> np.ndarray:
    """Put the default posture's contacts on the ground z = 0, without penetration.

    Gauss-Newton on the joints (root fixed), least-norm steps, on the error of every
    contact relative to the mean contact height: (height, roll, pitch) of a surface's frame,
    the height of a point contact's frame. Then the root is moved vertically so that the
    lowest contact touches z = 0 (the others are then at 0 too when the joints could level
    them; never below). Returns the new q (the input is not changed)."""
    data = model.createData()
    cs = [c for c in contacts.values() if c.kind in ("surface", "point")]
    if not cs:
        return q
    q = q.copy()
    fids = [(model.getFrameId(c.frame), c.kind == "surface") for c in cs]
    for _ in range(20):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        z_mean = np.mean([data.oMf[f].translation[2] for f, _ in fids])
        err, rows = [], []
        for f, surface in fids:
            M = data.oMf[f]
            J = pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED)
            err.append(M.translation[2] - z_mean)
            rows.append(J[2])
            if surface:
                rpy = pin.rpy.matrixToRpy(M.rotation)
                err += [rpy[0], rpy[1]]
                rows += [J[3], J[4]]
        err = np.array(err)
        if np.abs(err).max() < 1e-10:
            break
        A = np.array(rows)[:, 6:]
        dq = np.zeros(model.nv)
        dq[6:] = -np.linalg.lstsq(A, err, rcond=None)[0]
        q = pin.integrate(model, q, dq)
    pin.framesForwardKinematics(model, data, q)
    z = []
    for c in cs:
        M = data.oMf[model.getFrameId(c.frame)]
        if c.kind == "surface":
            z += [M.act(np.array([sx * c.half_length, sy * c.half_width, 0.0]))[2] for sx in (-1, 1) for sy in (-1, 1)]
        else:
            z.append(M.translation[2])
    q[2] -= min(z)
    return q


# ----------------------------------------------------------------- load-time checks
def static_torques(robot) -> np.ndarray:
    """Joint torques (nv; N·m or N; 0 on unactuated coordinates) that hold the default
    posture q₀ at rest against gravity.

    Fixed or actuated root: τ = g(q₀). Free-flyer root with contacts: the least
    ‖τ‖² with S^T τ + Σ_c J_cᵀ f_c = g(q₀), i.e. τ = g_j − J_jᵀ f with f minimising
    ‖g_j − J_jᵀ f‖² subject to the base rows J_bᵀ f = g_b (a KKT system; f a 3-D force
    at a point contact, a 6-D wrench at a surface; unilaterality and friction are not
    imposed, so this is a lower bound on what standing needs)."""
    m = robot.model
    d = m.createData()
    q0 = robot.q_default
    g = pin.computeGeneralizedGravity(m, d, q0).copy()
    if robot.root != "free_flyer" or robot.actuated_root:
        return np.where(robot.actuated_mask, g, 0.0)
    if not robot.contacts:
        return np.zeros(robot.nv)
    pin.computeJointJacobians(m, d, q0)
    pin.updateFramePlacements(m, d)
    J = []
    for c in robot.contacts.values():
        Jc = pin.getFrameJacobian(m, d, m.getFrameId(c.frame), pin.LOCAL_WORLD_ALIGNED)
        J.append(Jc if c.kind == "surface" else Jc[:3])
    J = np.vstack(J)                   # nf × nv
    Jb, Jj = J[:, :6], J[:, 6:]
    gb, gj = g[:6], g[6:]
    nf = J.shape[0]
    # min ½‖gj − Jjᵀ f‖²  s.t. Jbᵀ f = gb
    K = np.block([[Jj @ Jj.T + 1e-9 * np.eye(nf), Jb], [Jb.T, np.zeros((6, 6))]])
    rhs = np.concatenate([Jj @ gj, gb])
    f = np.linalg.lstsq(K, rhs, rcond=None)[0][:nf]
    tau = np.zeros(robot.nv)
    tau[6:] = gj - Jj.T @ f
    return tau


def joint_name_of_v(model: pin.Model, iv: int) -> str:
    """Name of the joint that owns velocity coordinate ``iv``."""
    for j in range(1, model.njoints):
        if model.idx_vs[j] <= iv < model.idx_vs[j] + model.nvs[j]:
            return model.names[j]
    return f"v[{iv}]"


def robot_findings(robot) -> list[str]:
    """Problems of a loaded robot at its default posture (module docstring), one line each."""
    m, out = robot.model, []
    tau = static_torques(robot)
    for iv in robot.actuated_idx:
        lim = robot.tau_max[iv]
        if np.isfinite(lim) and abs(tau[iv]) > lim:
            out.append(f"joint '{joint_name_of_v(m, iv)}': holding the default posture against gravity needs "
                       f"{abs(tau[iv]):.1f} N·m, above its torque limit {lim:g} N·m (raise limits.torque if the "
                       "robot has a counterbalance, or change the posture)")
    for j in range(1, m.njoints):
        if m.joints[j].nq != 1 or (j == 1 and robot.root != "fixed" and m.names[j] == "root_joint"):
            continue
        i = m.idx_qs[j]
        if not robot.q_min[i] - 1e-9 <= robot.q_default[i] <= robot.q_max[i] + 1e-9:
            out.append(f"joint '{m.names[j]}': default posture {robot.q_default[i]:.4g} outside its position "
                       f"limits [{robot.q_min[i]:.4g}, {robot.q_max[i]:.4g}]")
    d = m.createData()
    pin.framesForwardKinematics(m, d, robot.q_default)
    for c in robot.contacts.values():
        z = d.oMf[m.getFrameId(c.frame)].rotation[2, 2]
        if z < math.cos(CONTACT_TILT_WARN):
            tilt = math.degrees(math.acos(max(-1.0, min(1.0, z))))
            out.append(f"contact '{c.name}' (frame '{c.frame}'): its z axis is {tilt:.0f}° "
                       "from the vertical at the default posture (the contact normal is the frame's +z)")
    return out


def check_robot(robot) -> list[str]:
    """Issue a :class:`RobotWarning` for each of :func:`robot_findings`; returns them."""
    found = robot_findings(robot)
    for msg in found:
        warnings.warn(f"robot '{robot.name}': {msg}", RobotWarning, stacklevel=3)
    return found
