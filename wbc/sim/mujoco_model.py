"""The MuJoCo model of a robot, compiled at run time from its own URDF (:mod:`wbc.sim.mujoco_sim`
has the conventions): the URDF's joints and inertias, a free, planar or fixed root, sole boxes
and contact spheres at the robot's contact points, one motor per actuated joint with
``ctrlrange`` = ±τ_max, the scenario's ground, incline, planes, boxes, spheres and cylinders with their μ, and explicit
contact pairs for the points that carry their own MuJoCo contact parameters.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import pinocchio as pin

from ..errors import WbcError
from .environment import Box, Cylinder, HalfSpace, Sphere

if TYPE_CHECKING:
    from wbc.robot.model import RobotModel

    from .options import SimOptions

SOLE_THICKNESS = 0.01   # m, the sole boxes' height
POINT_RADIUS = 0.005    # m, the point contacts' spheres


def _link_of(joint: ET.Element, key: str) -> str:
    """The link a URDF joint's ``parent`` or ``child`` element names."""
    e = joint.find(key)
    link = None if e is None else e.get("link")
    if link is None:
        raise WbcError(f"mujoco: URDF joint '{joint.get('name')}' has no {key} link")
    return link


def _urdf_xml(robot: RobotModel, keep_inertials: bool) -> str:
    """The robot's URDF without visuals/collisions/transmissions; locked joints made fixed at
    the placement pinocchio locked them at (child link frame relative to the parent link's)."""
    if robot.urdf_path is None:
        raise WbcError(f"mujoco: robot '{robot.name}' was not built from a URDF file, which MuJoCo's model is made of")
    tree = ET.parse(robot.urdf_path).getroot()
    for tag in ("transmission", "gazebo", "mujoco"):
        for e in tree.findall(tag):
            tree.remove(e)
    for link in tree.iter("link"):
        for tag in ("visual", "collision") + (() if keep_inertials else ("inertial",)):
            for e in link.findall(tag):
                link.remove(e)
    m = robot.model
    for joint in tree.iter("joint"):
        locked = joint.get("name") in robot.locked_joints   # pinocchio leaves mimic joints independent
        for tag in ("mimic",) + (("origin", "axis", "limit", "dynamics", "calibration", "safety_controller")
                                 if locked else ()):
            for e in joint.findall(tag):
                joint.remove(e)
        if not locked:
            continue
        fp, fc = (m.frames[m.getFrameId(_link_of(joint, k))] for k in ("parent", "child"))
        rel = fp.placement.actInv(fc.placement)
        joint.set("type", "fixed")
        ET.SubElement(joint, "origin", xyz=" ".join(map(repr, rel.translation.tolist())),
                      rpy=" ".join(map(repr, pin.rpy.matrixToRpy(rel.rotation).tolist())))
    return ET.tostring(tree, encoding="unicode")


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    c = pin.Quaternion(R).coeffs()     # x y z w
    return np.array([c[3], c[0], c[1], c[2]])


def _pair_params(params: dict) -> dict:
    """A point contact's ``mujoco`` parameters as MjSpec pair attributes (solimp's midpoint and
    power MuJoCo's 0.5 and 2 when not given)."""
    out = {k: list(v) for k, v in params.items()}
    if "solimp" in out:
        out["solimp"] = (out["solimp"] + [0.5, 2.0][len(out["solimp"]) - 3:])[:5]
    return out


#: MuJoCo contact bit of the links' collision hulls (``link_geoms``): the environment's bodies have it in
#: their affinity, the ground and planes do not (bit 1 is the contact points')
LINK_CONTYPE = 2


def build_model(robot: RobotModel, environment: Sequence[HalfSpace | Box], points: list, timestep: float,
                options: SimOptions, tau_max: np.ndarray | None = None) -> mujoco.MjModel:
    """The MuJoCo model of ``robot`` (a :class:`~wbc.robot.model.RobotModel`) in ``environment``
    (shapes of :mod:`wbc.sim.environment`); ``points`` from :func:`contact_points`. See the
    module docstring for what it contains; ``timestep`` in s; ``options``: its ``joint_limits``,
    ``inertias``, ``joint_dynamics`` and ``link_geoms``; ``tau_max`` (nv, N·m or N) the
    motors' limits, the robot's by default. ``link_geoms``: (name, joint name, placement in the
    joint's frame, vertices n × 3 in m) of robot collision geometries to add as convex meshes
    (``wbc_link_<name>``) that collide with the environment: what MuJoCo's contact list then
    reports (:meth:`wbc.sim.mujoco_sim.MujocoSimulator.link_contacts`)."""
    joint_limits, inertias, joint_dynamics, link_geoms = (options.joint_limits, options.inertias,
                                                          options.joint_dynamics, options.link_geoms)
    if inertias not in ("model", "urdf"):
        raise WbcError(f"mujoco: inertias must be 'model' or 'urdf', got {inertias!r}")
    m = robot.model
    spec = mujoco.MjSpec.from_string(_urdf_xml(robot, keep_inertials=inertias == "urdf"))
    spec.compiler.fusestatic = True
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.balanceinertia = False
    spec.option.timestep = timestep
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.gravity = m.gravity.linear.copy()
    root = spec.worldbody.first_body()
    if robot.root == "free_flyer":
        root.add_freejoint(name=m.names[1])
    elif robot.root == "planar":
        root.add_joint(name="root_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
        root.add_joint(name="root_y", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0])
        root.add_joint(name="root_yaw", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    for j in spec.joints:
        i = m.idx_vs[m.getJointId(j.name)] if joint_dynamics and m.existJointName(j.name) else None
        j.damping[:] = 0.0          # mjNPOLY + 1 coefficients since 4.x
        j.damping[0] = 0.0 if i is None else m.damping[i]
        j.frictionloss, j.armature = 0.0 if i is None else m.friction[i], 0.0
        j.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
        if not joint_limits and j.type != mujoco.mjtJoint.mjJNT_FREE:
            j.limited = mujoco.mjtLimited.mjLIMITED_FALSE

    def body_of(jid: int):
        if jid == 0:
            return spec.worldbody
        return root if jid == 1 and robot.root != "fixed" else spec.joint(m.names[jid]).parent

    for jid in range(1, m.njoints) if inertias == "model" else ():
        Y, b = m.inertias[jid], body_of(jid)
        I = Y.inertia
        b.mass, b.ipos, b.explicitinertial = Y.mass, Y.lever.copy(), True
        b.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
    robot_geom = dict(contype=1, conaffinity=0, condim=3, group=3)
    paired = []      # (point geom name, its contact's MuJoCo parameters): explicit pairs below
    for i, (jname, r, kind, R, cname) in enumerate(points):
        b = body_of(m.getJointId(jname))
        b.add_site(name=f"wbc_point_{i}", pos=r)
        if kind == "point":
            c = robot.contacts.get(cname)
            params = dict(c.mujoco) if c is not None and c.mujoco else None
            geom = dict(robot_geom, contype=0) if params else robot_geom
            b.add_geom(name=f"wbc_point_geom_{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                       pos=r + POINT_RADIUS * R[:, 2], size=[POINT_RADIUS, 0, 0], **geom)
            if params:
                paired.append((f"wbc_point_geom_{i}", params))
    # chosen links' collision hulls, against the environment's bodies (boxes, spheres, cylinders): their own
    # contact bit, so that they never touch the ground or a plane (the robot stands on its contact points)
    link_geom = dict(robot_geom, contype=LINK_CONTYPE)
    for gname, jname, M, verts in link_geoms:
        spec.add_mesh(name=f"wbc_mesh_{gname}", uservert=np.asarray(verts, dtype=float).ravel().tolist())
        body_of(m.getJointId(jname)).add_geom(name=f"wbc_link_{gname}", type=mujoco.mjtGeom.mjGEOM_MESH,
                                              meshname=f"wbc_mesh_{gname}", pos=M.translation,
                                              quat=_quat_wxyz(M.rotation), **link_geom)
    for c in (c for c in robot.contacts.values() if c.kind == "surface"):
        f = m.frames[m.getFrameId(c.frame)]
        M = f.placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, SOLE_THICKNESS / 2]))
        body_of(f.parentJoint).add_geom(name=f"wbc_contact_{c.name}", type=mujoco.mjtGeom.mjGEOM_BOX,
                                        pos=M.translation, quat=_quat_wxyz(M.rotation),
                                        size=[c.half_length, c.half_width, SOLE_THICKNESS / 2], **robot_geom)
    for k, s in enumerate(environment):
        env = dict(contype=0, conaffinity=1 if isinstance(s, HalfSpace) else 1 | LINK_CONTYPE, condim=3, priority=1,
                   friction=[s.mu, 0.005, 0.0001])
        if isinstance(s, HalfSpace):
            spec.worldbody.add_geom(name=f"env_{k}_{s.name}", type=mujoco.mjtGeom.mjGEOM_PLANE, pos=s.point,
                                    quat=_quat_wxyz(s.R), size=[0, 0, 1], **env)
        elif isinstance(s, Box):
            spec.worldbody.add_geom(name=f"env_{k}_{s.name}", type=mujoco.mjtGeom.mjGEOM_BOX, pos=s.center,
                                    size=s.size / 2, **env)
        elif isinstance(s, Sphere):
            spec.worldbody.add_geom(name=f"env_{k}_{s.name}", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=s.center,
                                    size=[s.radius, 0, 0], **env)
        elif isinstance(s, Cylinder):
            spec.worldbody.add_geom(name=f"env_{k}_{s.name}", type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=s.center,
                                    size=[s.radius, s.length / 2, 0], **env)
        else:
            raise WbcError(f"mujoco: unsupported environment shape {type(s).__name__}")
        for gname, params in paired:      # what the priority rule gives, with the point's solref/solimp
            spec.add_pair(geomname1=f"env_{k}_{s.name}", geomname2=gname, condim=3,
                          friction=[s.mu, s.mu, 0.005, 0.0001, 0.0001], **_pair_params(params))

    tau_max = robot.tau_max if tau_max is None else tau_max
    for i in robot.actuated_idx:
        lim = float(tau_max[i])
        rng = dict(ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE, ctrlrange=[-lim, lim]) if math.isfinite(lim) \
            else dict(ctrllimited=mujoco.mjtLimited.mjLIMITED_FALSE)
        if i < robot.n_root:        # actuated root: a site motor along the root's i-th axis
            if not spec.site("wbc_root"):
                root.add_site(name="wbc_root")
            gear = np.zeros(6)
            gear[{"planar": (0, 1, 5), "free_flyer": tuple(range(6))}[robot.root][i]] = 1.0
            spec.add_actuator(name=f"wbc_root_{i}", trntype=mujoco.mjtTrn.mjTRN_SITE, target="wbc_root",
                              gear=gear, **rng)
        else:
            jid = int(np.searchsorted(m.idx_vs, i, side="right")) - 1
            spec.add_actuator(name=m.names[jid], trntype=mujoco.mjtTrn.mjTRN_JOINT, target=m.names[jid], **rng)
    return spec.compile()
