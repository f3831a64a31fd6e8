"""MuJoCo as a second physics back-end: :class:`MujocoSimulator`, the interface of
:class:`wbc.sim.Simulator` on a MuJoCo model built at run time from the robot's URDF.

Model (:func:`wbc.sim.mujoco_model.build_model`; SI units: m, kg, s, rad, N, N·m)
- Tree: MuJoCo's URDF parser on the URDF without visuals, collisions, transmissions, mimic tags;
  ``fusestatic`` fuses fixed-joint links into their parents: bodies and pinocchio joints match one
  to one, a body's frame is its joint's. Joints the YAML locks are fixed where pinocchio locked them.
- Root: ``free_flyer`` -> free joint; ``planar`` -> slide x, slide y (world), hinge z; ``fixed`` -> welded.
- Inertias: ``inertias="model"`` (default): pinocchio's inertia of each joint (URDF inertials, fixed
  links merged), as MuJoCo refuses URDF inertials pinocchio takes (TIAGo's antenna links are not
  positive definite); ``"urdf"``: MuJoCo reads them (Talos, Panda: equal to 1e-14).
- Joint damping and dry friction zeroed, or (``joint_dynamics=True``) pinocchio's URDF values (the
  URDF's ``<dynamics>``, which MuJoCo's parser reads equally): ``damping`` (implicit in MuJoCo's Euler)
  and ``frictionloss`` (MuJoCo's soft dry-friction constraint, default solref/solimp); armature zeroed;
  position limits kept as MuJoCo's soft limits (``joint_limits=False`` drops them).
- A motor per actuated joint, ``ctrlrange`` ±τ_max (``tau_limits``, default the robot's): MuJoCo
  saturates (the URDF effort's joint ``actuatorfrcrange`` is cleared). An actuated root (TIAGo) has
  site motors at the root origin geared along the base axes (force x, y, torque z, base frame).
- Contacts: under each sole a box of the YAML's half_length × half_width, 1 cm thick, bottom face on
  the sole plane; a sphere (r 5 mm) touching each point contact; sites at Simulator.for_robot's
  points. Robot geoms touch the environment only: HalfSpace -> plane, Box -> box (all its faces; in
  wbc.sim its top only), with its μ (geom priority), condim 3, elliptic cones. A point contact
  with ``mujoco:`` parameters (a scenario's ``contacts:``, :mod:`wbc.scenario.contacts`) touches
  them through explicit pairs instead: the same μ and condim, its solref / solimp /
  solreffriction (MuJoCo's defaults for those not given; with none given a pair is bit-identical
  to the priority rule's contact).
- Options: timestep dt / substeps, MuJoCo's defaults otherwise (Euler, Newton, solref, solimp; no
  impratio or noslip tuning); pinocchio's gravity.

Conventions (each checked numerically in tests/sim/test_mujoco_model.py)
- q = [p, quaternion x y z w, joints in pinocchio's order] <-> qpos = [p, quaternion w x y z, joints
  in MuJoCo's order], mapped by name; planar [x, y, cos θ, sin θ] <-> [x, y, θ]; continuous (cos, sin) <-> angle.
- Free flyer v = [Rᵀ ṗ, ω_b] (base frame), qvel = [ṗ (world), ω_b]; planar v = [R(θ)ᵀ(ẋ, ẏ), θ̇],
  qvel = [ẋ, ẏ, θ̇]. So qvel = T(q) v, T = blockdiag(R, I) with the joints permuted (orthogonal),
  q̈_mj = T v̇ + Ṫ v, Ṫ v = [R (ω × v_lin), 0] (planar: θ̇ R(θ) (−v_y, v_x)).
- Dynamics: M = Tᵀ M_mj T, h = Tᵀ (M_mj Ṫ v + h_mj), τ = Tᵀ τ_mj.
- ``xfrc_applied`` acts at the body's CoM c (``xipos``): a push f at the frame origin p is applied
  as (f, (p − c) × f), the same wrench about every point as f at p.
- ``mj_contactForce``: geom1's force on geom2 in ``contact.frame`` (rows: normal from geom1 to geom2,
  tangents). Each contact's force is kept with its point in the body's frame (:meth:`contact_wrench`
  about a frame's origin, as Simulator's) and added to its geom's nearest point (``point_forces``, world).

Point contacts sliding (the wipe scenarios): MuJoCo's contact is convex and soft. At a sliding
contact (force on the elliptic cone's surface) the friction rows' reference acceleration
−b v_t (b = 2/(d_max t_c), solref's) is met only up to the cone, and the remainder acts along
the cone's normal, which has a component −μ along the contact normal: the contact accelerates
apart by about μ(b|v_t| − μ R_t f_n), against the R_n f_n that holds the penetration under a
force f_n (R = (1 − d)/d × MuJoCo's inverse-mass estimate). The point separates once
μ b |v_t| ≳ R_n f_n. Measured (tiago_wipe, defaults, 10 N, μ 0.3): 0.38 mm of penetration at
rest, gone at a sliding speed of 4 cm/s, then the pad hops (61 contact-lost cycles, force RMS
error 2.3 N); the lift is linear in the speed, ≈ 10 mm per m/s, independent of the mass. Raising
R (a softer solimp) deepens the rest penetration; lowering the friction rows' b (solreffriction
with a longer time constant) lowers the lift but widens the creep below which friction is
viscous (< μ f_n until |v_t| ≈ μ R_t f_n / b). Both are per-contact choices of a scenario
(``mujoco:`` on its point contact), not changes of MuJoCo's defaults.

Differential drive (TIAGo): MuJoCo's equalities are holonomic, so the zero lateral base velocity is
imposed as :class:`Simulator` does, along e = [−sin θ, cos θ, 0] (qvel coordinates): before the step
a generalized force e λ, λ = −eᵀ v_free / (h eᵀ M⁻¹ e), v_free = qvel + h q̈ of ``mj_forward`` (exact
without active contacts or limits); after it, the impulse along the new heading's e zeroing eᵀ qvel.

Factory: ``MujocoSimulator.for_robot(robot, environment, q0=None, extra_points=(), **kw)`` takes
Simulator.for_robot's arguments (``dt``, ``substeps``, ``tau_limits``, ``noise_q``, ``noise_v``,
``latency_steps``, ``seed``; ``baumgarte``, ``margin`` accepted, unused): the runner can build either
class; :func:`wbc.sim.backends.make_simulator` picks one by name.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import pinocchio as pin

from ..errors import WbcError
from .bodies import Push, contact_points
from .environment import Box, HalfSpace
from .mujoco_contacts import GeomPoints, read_contacts
from .mujoco_model import build_model
from .mujoco_state import Coordinates, StateReader, command
from .options import SimOptions

if TYPE_CHECKING:
    from wbc.robot.model import RobotModel

#: the warnings on which MuJoCo resets the state (a diverged step)
_BAD = np.array([mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC],
                dtype=np.int64)
_BAD_IDS = tuple(int(k) for k in _BAD)

class MujocoSimulator(Coordinates):
    """:class:`wbc.sim.Simulator`'s interface on MuJoCo (module docstring). Units: s, m, rad, N, N·m.

    As Simulator's: ``model``, ``data`` (pinocchio, owned), ``q``, ``v`` (pinocchio coordinates,
    updated by each step), ``t``, ``dt``, ``substeps``, ``h``, ``points`` ((pinocchio joint id,
    offset in its frame)), ``point_forces`` (world, N, last step), ``pushes``, ``env``,
    ``solver_failures`` (MuJoCo's resets of a bad position, velocity or acceleration),
    ``saturated_steps``;
    MuJoCo's ``mj_model``, ``mj_data``; the coordinate maps of :class:`~wbc.sim.mujoco_state.Coordinates`.
    """

    def __init__(self, robot: RobotModel, environment: Sequence[HalfSpace | Box], q0: np.ndarray | None = None,
                 v0: np.ndarray | None = None, extra_points=(), options: SimOptions | None = None,
                 **settings) -> None:
        """Args:
            robot: the simulated robot.
            environment: shapes of :mod:`wbc.sim.environment`.
            q0: initial configuration (nq); None: the robot's default.
            v0: initial velocity (nv); None: zero.
            extra_points: more contact points, ``(frame name, offset in the frame, m)``.
            options: :class:`~wbc.sim.options.SimOptions` (``baumgarte``, ``margin``,
                ``contact_solver``, ``actuated``, ``differential_drive`` unused: the robot's).
            **settings: its fields one by one, over ``options``.
        """
        o = self.options = SimOptions.of(options, settings, "MujocoSimulator")
        dt, substeps, tau_limits, link_geoms = o.dt, o.substeps, o.tau_limits, o.link_geoms
        self.robot, self.model, self.root = robot, robot.model, robot.root
        m = self.model
        self.data = m.createData()
        self.env = list(environment)
        self.dt, self.substeps = float(dt), int(substeps)
        self.h = self.dt / self.substeps
        self.actuated = robot.actuated_mask.copy()
        self.differential_drive = bool(robot.differential_drive)
        pts = contact_points(robot, extra_points)
        self.points = [(m.getJointId(p[0]), np.asarray(p[1], float)) for p in pts]
        lim = np.asarray(robot.tau_max if tau_limits is None else tau_limits, float)
        self.tau_limits = lim.copy() if lim.shape[0] == m.nv else np.where(self.actuated, 0.0, np.inf)
        if lim.shape[0] != m.nv:
            self.tau_limits[self.actuated] = lim
        self.mj_model = mm = build_model(robot, self.env, pts, self.h, o, self.tau_limits)
        #: MuJoCo geom id -> name of the links' collision geometries added (``link_geoms``)
        self._link_geoms = {mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_GEOM, f"wbc_link_{g[0]}"): g[0]
                            for g in link_geoms}
        #: the robot geometries added with ``link_geoms`` (what :meth:`link_contacts` watches)
        self.link_geom_names = [g[0] for g in link_geoms]
        self.mj_data = mujoco.MjData(mm)
        self._warned = self.mj_data.warning.number      # a view: the counts of each warning, live
        # pinocchio joint -> MuJoCo body, and the (q, v) <-> (qpos, qvel) indices of the joints
        self._body = np.zeros(m.njoints, int)
        self._n_root = {"free_flyer": 6, "planar": 3, "fixed": 0}[robot.root]
        self._body[1] = mm.jnt_bodyid[0] if self._n_root else 0
        qi, qm, vi, vm, self._cont = [], [], [], [], []
        for jid in range(1 + bool(self._n_root), m.njoints):
            mj, jm = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_JOINT, m.names[jid]), m.joints[jid]
            self._body[jid] = mm.jnt_bodyid[mj]
            if jm.nq == 2:
                self._cont.append((jm.idx_q, mm.jnt_qposadr[mj]))
            else:
                qi.append(jm.idx_q)
                qm.append(mm.jnt_qposadr[mj])
            vi.append(jm.idx_v)
            vm.append(mm.jnt_dofadr[mj])
        self._qi, self._qm, self._vi, self._vm = (np.array(x, int) for x in (qi, qm, vi, vm))
        self._root_q = int(mm.jnt_qposadr[0]) if self._n_root else 0
        self._root_v = int(mm.jnt_dofadr[0]) if self._n_root else 0
        self._T0: np.ndarray | None = None      # velocity_map's constant part
        self._T: np.ndarray | None = None       # v_from_qvel's T(q)
        self._act_v = np.asarray(robot.actuated_idx, int)   # actuator k drives pinocchio dof _act_v[k]
        self._act_limits = self.tau_limits[self._act_v]     # the motors' ±τ_max (N·m, N), in actuator order
        self._ctrl, self._xfrc = self.mj_data.ctrl, self.mj_data.xfrc_applied     # views, held
        # the compiled state read-out (mujoco_state.read_state): a free-flyer or fixed root, and
        # only where it reproduces the general path on this host
        reader = StateReader(np.array([self._root_q, self._root_v, self.root == "free_flyer"], dtype=np.int64),
                             (self._qi, self._qm, self._vi, self._vm), self._cont, m.nq, m.nv)
        self._reader = (reader if self.root in ("free_flyer", "fixed") and reader.holds(self._general_state, mm.nq, mm.nv)
                        else None)
        gp: dict[int, list] = {}
        for i, (_, r, kind, _, cname) in enumerate(pts):
            g = mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_GEOM,
                                  f"wbc_contact_{cname}" if kind == "surface" else f"wbc_point_geom_{i}")
            gp.setdefault(g, []).append((i, r))
        # robot geom -> (its points' indices, their offsets in the body frame)
        self._geom_points = {g: (np.array([i for i, _ in v]), np.array([r for _, r in v])) for g, v in gp.items()}
        if mm.opt.cone != mujoco.mjtCone.mjCONE_ELLIPTIC:     # read_contacts reads efc_force as mj_contactForce does then
            raise WbcError("MujocoSimulator: the contact read-out needs elliptic friction cones")
        self._geom_table = GeomPoints(mm.ngeom, self._geom_points, mm.geom_bodyid).args
        self._sites = np.array([mujoco.mj_name2id(mm, mujoco.mjtObj.mjOBJ_SITE, f"wbc_point_{i}")
                                for i in range(len(pts))], int)
        self.pushes: list[Push] = []
        self.point_forces = np.zeros((len(pts), 3))
        # the last step's robot contacts (body, point, force; body frame): the first _ncontacts rows
        self._cbody, self._cpoint, self._cforce = np.zeros(16, dtype=np.int64), np.zeros((16, 3)), np.zeros((16, 3))
        self._ncontacts = 0
        self._rng = np.random.default_rng(o.seed)
        self.noise_q, self.noise_v = o.noise_q, o.noise_v
        self._delay: deque = deque(maxlen=o.latency_steps + 1)
        self.solver_failures = self.saturated_steps = 0
        self._servo = False             # the joint motors turned position actuators (step_position)
        self._f6 = np.zeros(6)
        self.t = 0.0
        self.set_state(robot.q_default if q0 is None else q0, np.zeros(m.nv) if v0 is None else v0)

    @classmethod
    def for_robot(cls, robot: RobotModel, environment: Sequence[HalfSpace | Box], q0: np.ndarray | None = None,
                  extra_points=(), options: SimOptions | None = None, v0: np.ndarray | None = None,
                  **settings) -> MujocoSimulator:
        """Simulator.for_robot's arguments: the sole corners and point contacts of ``robot``'s
        YAML, ``extra_points`` more ``(frame name, offset in the frame)``; ``kwargs``: ``dt``,
        ``substeps``, ``tau_limits``, sensing (``noise_q``, ``noise_v``, ``latency_steps``,
        ``seed``), and ``joint_limits``, ``inertias``, ``v0``, ``joint_dynamics``."""
        return cls(robot, environment, q0, v0, extra_points, SimOptions.of(options, settings, "MujocoSimulator"))

    # ----------------------------------------------------------- state, frames
    def set_state(self, q: np.ndarray, v: np.ndarray) -> None:
        """Set MuJoCo's state from pinocchio's (q, v) and run ``mj_forward``."""
        d = self.mj_data
        d.qpos[:] = self.qpos_from_q(np.asarray(q, float))
        d.qvel[:] = self.qvel_from_v(q, np.asarray(v, float))
        mujoco.mj_forward(self.mj_model, d)
        self._read_state()

    def _read_state(self) -> None:
        """q, v of MuJoCo's qpos, qvel: one compiled call (:class:`~wbc.sim.mujoco_state.StateReader`)
        where it holds, else (and at a non-finite qvel) :meth:`q_from_qpos`, :meth:`v_from_qvel`."""
        d = self.mj_data
        self._fresh = 0
        got = self._reader.read(d.qpos, d.qvel) if self._reader is not None else None
        if got is not None:
            self.q, self.v = got
        else:
            self.q = self.q_from_qpos(d.qpos)
            self.v = self.v_from_qvel(self.q, d.qvel)

    def _kinematics(self, com_pos: bool = False) -> None:
        """Kinematics of the current qpos (mj_step leaves those of the state it integrated from):
        the bodies' and sites' placements (``mj_kinematics``), and with ``com_pos`` the subtree
        CoMs and motion dofs ``mj_jac`` reads (``mj_comPos``). ``_fresh``: 0 none, 1 the
        placements, 2 both."""
        if self._fresh < 1:
            mujoco.mj_kinematics(self.mj_model, self.mj_data)
            self._fresh = 1
        if com_pos and self._fresh < 2:
            mujoco.mj_comPos(self.mj_model, self.mj_data)
            self._fresh = 2

    def _frame(self, frame: str) -> pin.Frame:
        if not self.model.existFrame(frame):
            raise WbcError(f"simulator: no frame '{frame}'")
        return self.model.frames[self.model.getFrameId(frame)]

    def frame_placement(self, frame: str) -> pin.SE3:
        """World placement (m) of a pinocchio frame, from its MuJoCo body's pose now."""
        self._kinematics()
        f = self._frame(frame)
        b, d = self._body[f.parentJoint], self.mj_data
        return pin.SE3(d.xmat[b].reshape(3, 3).copy(), d.xpos[b].copy()) * f.placement

    def frame_velocity(self, frame: str) -> np.ndarray:
        """(linear, angular) velocity (m/s, rad/s) of a frame's origin in world axes (pinocchio's
        LOCAL_WORLD_ALIGNED), from MuJoCo's point Jacobian and qvel."""
        p = self.frame_placement(frame).translation
        self._kinematics(com_pos=True)
        jp, jr = np.zeros((3, self.mj_model.nv)), np.zeros((3, self.mj_model.nv))
        mujoco.mj_jac(self.mj_model, self.mj_data, jp, jr, p, self._body[self._frame(frame).parentJoint])
        return np.concatenate([jp @ self.mj_data.qvel, jr @ self.mj_data.qvel])

    # ----------------------------------------------------------- pushes
    def push(self, frame: str, force, start: float, duration: float) -> None:
        """Schedule an external force (N, world) on ``frame`` (a model frame name)."""
        if not self.model.existFrame(frame):
            raise WbcError(f"simulator: no frame '{frame}' to push")
        self.pushes.append(Push(frame, np.asarray(force, float), float(start), float(duration)))

    def push_wrenches(self, t: float) -> np.ndarray:
        """``xfrc_applied`` (nbody × 6, N and N·m, world) of the pushes active at t (s): the
        force and its moment about the body's CoM."""
        x = np.zeros((self.mj_model.nbody, 6))
        for p in self.pushes:
            if p.active(t):
                b = self._body[self._frame(p.frame).parentJoint]
                r = self.frame_placement(p.frame).translation - self.mj_data.xipos[b]
                x[b, :3] += p.force
                x[b, 3:] += np.cross(r, p.force)
        return x

    # ----------------------------------------------------------- stepping
    def step(self, tau: np.ndarray) -> None:
        """Advance one control period with joint torques ``tau`` (N·m or N; nv, or na actuated),
        saturated by the motors' ``ctrlrange``."""
        tau = np.asarray(tau, dtype=float)
        if tau.ndim == 1 and tau.shape[0] in (self.model.nv, self._ctrl.shape[0]):
            # one compiled call: ctrl, the saturation count, xfrc_applied zeroed (mujoco_state.command)
            s = command(tau, tau.shape[0] == self.model.nv, self._act_v, self._act_limits, self._ctrl, self._xfrc)
            if s < 0:
                raise WbcError("simulator: non-finite torque")
            self.saturated_steps += s
            self._advance(zeroed=True)
            return
        if tau.shape[0] == self.model.nv:
            tau = tau[self._act_v]
        if not np.all(np.isfinite(tau)):
            raise WbcError("simulator: non-finite torque")
        self.mj_data.ctrl[:] = tau
        self.saturated_steps += bool(np.any(np.abs(tau) > self.tau_limits[self._act_v]))
        self._advance()

    def step_position(self, q_cmd: np.ndarray, v_cmd: np.ndarray, kp: np.ndarray, kd: np.ndarray,
                      tau_ff: np.ndarray | None = None) -> None:
        """Advance one control period with position-controlled actuators (:mod:`wbc.robot.servo`):
        each joint motor becomes a MuJoCo position actuator (gain k_p, bias −k_p q − k_d q̇, force
        range ±τ_max) on its first call, commanded ctrl = q + (q_cmd ⊖ q) + (k_d q̇_cmd + τ_ff)/k_p, so
        that its force is τ_ff + k_p (q_cmd ⊖ q) + k_d (q̇_cmd − q̇) at every MuJoCo step. An actuated root
        (TIAGo's site motors, which have no joint position) gets the same law as a torque held over
        the period.

        Args:
            q_cmd: commanded configuration (nq, pinocchio's coordinates).
            v_cmd: commanded velocity (nv).
            kp: servo stiffnesses (nv; N·m/rad, N/m).
            kd: servo dampings (nv; N·m·s/rad, N·s/m).
            tau_ff: feed-forward torque held over the period (nv; N·m, N); None: none.
        """
        mm, d = self.mj_model, self.mj_data
        act = self._act_v
        joint = mm.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT
        if not self._servo:
            k = np.flatnonzero(joint)
            mm.actuator_gainprm[k, 0] = kp[act[k]]
            mm.actuator_biastype[k] = mujoco.mjtBias.mjBIAS_AFFINE
            mm.actuator_biasprm[k, :3] = np.column_stack([np.zeros(len(k)), -kp[act[k]], -kd[act[k]]])
            mm.actuator_forcerange[k] = mm.actuator_ctrlrange[k]
            mm.actuator_forcelimited[k] = 1
            mm.actuator_ctrllimited[k] = 0
            self._servo = True
        err = pin.difference(self.model, self.q, np.asarray(q_cmd, dtype=float))
        v_cmd = np.asarray(v_cmd, dtype=float)
        ff = np.zeros(self.model.nv) if tau_ff is None else np.asarray(tau_ff, dtype=float)
        shift = np.divide(kd * v_cmd + ff, kp, out=np.zeros_like(kd), where=kp > 0)
        qj = d.qpos[mm.jnt_qposadr[mm.actuator_trnid[:, 0]]]
        ctrl = np.where(joint, qj + err[act] + shift[act], 0.0)
        root = ~joint
        if root.any():
            tau = ff[act] + kp[act] * err[act] + kd[act] * (v_cmd[act] - self.v[act])
            ctrl[root] = np.clip(tau[root], -self.tau_limits[act][root], self.tau_limits[act][root])
        d.ctrl[:] = ctrl
        self._advance()

    def _advance(self, zeroed: bool = False) -> None:
        """``substeps`` MuJoCo steps at the current ctrl, then the contacts and the state read.

        Args:
            zeroed: ``xfrc_applied`` already zeroed for the first step (:func:`~wbc.sim.mujoco_state.command`).
        """
        mm, d = self.mj_model, self.mj_data
        for k in range(self.substeps):
            if self.pushes:
                d.xfrc_applied[:] = self.push_wrenches(self.t)
            elif k or not zeroed:
                d.xfrc_applied[:] = 0.0
            if self.differential_drive:
                d.qfrc_applied[:] = 0.0
                mujoco.mj_forward(mm, d)
                e, Me = self._lateral()
                d.qfrc_applied[:] = e * (-(e @ (d.qvel + self.h * d.qacc)) / (self.h * (e @ Me)))
            n_bad = self._bad_warnings()
            mujoco.mj_step(mm, d)
            self._fresh = 0
            if self.differential_drive:       # the impulse along the new heading's lateral axis
                e, Me = self._lateral()
                d.qvel[:] -= Me * ((e @ d.qvel) / (e @ Me))
            self.solver_failures += self._bad_warnings() - n_bad
            self.t += self.h
        self._read_contacts()
        self._read_state()

    def _bad_warnings(self) -> int:
        """How many times MuJoCo has issued the warnings on which it resets the state (a diverged
        step: a bad qpos, qvel or qacc), read from its live counts as three Python ints (the same
        sum as ``warned[_BAD].sum()``, without the index array and the reduction: twice a step)."""
        w, (a, b, c) = self._warned, _BAD_IDS
        return int(w[a]) + int(w[b]) + int(w[c])

    def _lateral(self) -> tuple[np.ndarray, np.ndarray]:
        """The base's lateral axis e (qvel coordinates) and M⁻¹e (MuJoCo's last factorization)."""
        mm, d = self.mj_model, self.mj_data
        th = d.qpos[self._root_q + 2]
        e, Me = np.zeros(mm.nv), np.zeros(mm.nv)
        e[self._root_v: self._root_v + 2] = -math.sin(th), math.cos(th)
        mujoco.mj_solveM(mm, d, Me.reshape(1, -1), e.reshape(1, -1))
        return e, Me

    def _read_contacts(self) -> None:
        """The last step's contact forces on the robot (world, N): each kept with its point in
        the body's frame, and added to the nearest of its geom's points
        (:func:`~wbc.sim.mujoco_contacts.read_contacts`, one compiled call)."""
        d = self.mj_data
        con = d.contact
        if d.ncon > len(self._cbody):
            n = 2 * d.ncon
            self._cbody, self._cpoint, self._cforce = np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.zeros((n, 3))
        self._ncontacts = read_contacts(con.geom, con.frame, con.pos, con.efc_address, con.dim, d.efc_force, d.xmat,
                                        d.xpos, self._geom_table, self.point_forces, self._cbody, self._cpoint,
                                        self._cforce)

    def link_contacts(self) -> list[tuple[str, str, float]]:
        """MuJoCo's own contact list, now, between the links' collision geometries added with
        ``link_geoms`` and anything else: (robot geometry name, the other geom's name,
        MuJoCo's distance, m, < 0 in penetration)."""
        mm, d = self.mj_model, self.mj_data
        out = []
        for k in range(d.ncon):
            c = d.contact[k]
            for g, other in ((int(c.geom1), int(c.geom2)), (int(c.geom2), int(c.geom1))):
                if g in self._link_geoms:
                    out.append((self._link_geoms[g], mujoco.mj_id2name(mm, mujoco.mjtObj.mjOBJ_GEOM, other) or "",
                                float(c.dist)))
                    break
        return out

    # ----------------------------------------------------------- sensing
    def measure(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) in pinocchio's coordinates, with Simulator's optional noise (``noise_q`` rad
        or m, ``noise_v`` rad/s or m/s) and ``latency_steps`` delay."""
        q, v = self.q.copy(), self.v.copy()
        if self.noise_q:
            q = pin.integrate(self.model, q, self._rng.normal(0.0, self.noise_q, self.model.nv))
        if self.noise_v:
            v = v + self._rng.normal(0.0, self.noise_v, self.model.nv)
        self._delay.append((q, v))
        return self._delay[0]

    def contact_wrench(self, frame: str) -> np.ndarray:
        """Wrench (f, τ) in the frame ``frame`` (N, N·m, about its origin) of the last step's
        contact forces on that frame's body (its joint's): what a 6-axis sensor there reads."""
        f = self._frame(frame)
        b, bMf = self._body[f.parentJoint], f.placement
        w = np.zeros(6)
        n = self._ncontacts
        for body, r, fb in zip(self._cbody[:n], self._cpoint[:n], self._cforce[:n], strict=True):
            if body == b:
                fl = bMf.rotation.T @ fb
                w[:3] += fl
                w[3:] += np.cross(bMf.actInv(r), fl)
        return w

    def point_positions(self) -> np.ndarray:
        """World positions (m) of the contact points at the current state."""
        self._kinematics()
        return self.mj_data.site_xpos[self._sites]       # (an index array: a copy)

    def com(self) -> np.ndarray:
        """World position (m) of the centre of mass at the current state (pinocchio's model
        and data, as :meth:`energy`)."""
        return pin.centerOfMass(self.model, self.data, self.q).copy()

    def energy(self) -> float:
        """Kinetic + gravitational potential energy (J) of the current state (pinocchio's)."""
        m, d = self.model, self.data
        return float(pin.computeKineticEnergy(m, d, self.q, self.v) + pin.computePotentialEnergy(m, d, self.q))

