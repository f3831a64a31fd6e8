"""RobotModel: the pinocchio model/data of one robot and the per-cycle cache.

``update(q, v)`` runs pinocchio's whole-body algorithms once per control cycle:

- ``forwardKinematics(q, q̇, 0)``: joint placements, velocities and the
  zero-acceleration bias accelerations (so frame drifts J̇q̇ come for free), then
  ``computeJointJacobians`` and ``updateFramePlacements`` from them;
- ``crba``: the joint-space inertia M(q) (the chapter's B(q)), in pinocchio's LOCAL
  convention (its default) for a robot whose deepest chain has at most
  :data:`DEEP_TREE` joints, in its WORLD convention (from the world-frame Jacobians, which
  the same forward pass gives) for a deeper one: the same M to rounding (~1e-16
  relative), ~3× faster on the 156-joint chain (385 → 131 µs), equal time on Talos
  (:func:`crba_convention`);
- ``nonLinearEffects``: h = C(q, q̇)q̇ + g(q) (5.1), minus a known external generalised
  force τ_e when one is given (``update(q, v, external_torque=τ_e)``: a measured or
  estimated push, :mod:`wbc.interaction.external_force`), so that every task and solver reads the
  dynamics M q̈ + h = Sᵀτ + J_fᵀ f with τ_e in it, plus the joints' damping and friction
  D q̇ + F tanh(q̇/v_s) when the robot YAML's ``compensate:`` asks (:mod:`wbc.robot.joint_compensation`);
- ``centerOfMass`` (with its drift J̇_com q̇, from the same forward pass) and
  ``jacobianCenterOfMass``.

These are the calls the cycle needs and no more: ``computeAllTerms`` gives the same
and more (centroidal terms, every joint's J̇, energies) in 20.5 µs against 13.2 µs
on Talos.

Tasks read the cache (``M``, ``h``, ``frame_jacobian`` ...) and never call
pinocchio's whole-body routines themselves. Frame Jacobians and drifts are
extracted lazily, once per frame and reference per cycle, or read by compiled rows from views
held once (:meth:`RobotModel.frame_arrays`, :mod:`wbc.robot.held_views`).

Units: q in m and rad (quaternion for a free-flyer, (cos, sin) for a planar joint),
v in m/s and rad/s, torques in N and N·m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from wbc.errors import FrameNotFound, TargetError
from wbc.robot.held_views import FrameArrays, HeldViews
from wbc.robot.joint_compensation import JointCompensation

LOCAL = pin.ReferenceFrame.LOCAL
WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass(frozen=True)
class ContactSurface:
    """A contact a robot can make: a sole rectangle (6-D wrench) or a point (3-D force).

    ``half_length`` (along the frame's x) and ``half_width`` (along y) in m;
    ``mu`` the Coulomb friction coefficient; the contact normal is the frame's +z.
    ``radius`` (m): a point foot's sphere radius (informative; the frame already is the
    touching point).
    """

    name: str
    frame: str
    kind: str = "surface"
    half_length: float = 0.1
    half_width: float = 0.05
    mu: float = 0.7
    #: a point contact's sphere radius (m): its frame is then the sphere's bottom at the
    #: default posture (:mod:`wbc.robot.extras`)
    radius: float = 0.0
    #: a point contact's MuJoCo contact parameters against the environment, as
    #: ``(("solref", (2,)), ("solimp", (3 to 5,)), ("solreffriction", (2,)))`` pairs (any subset);
    #: empty: MuJoCo's defaults (:mod:`wbc.scenario.contacts`, :mod:`wbc.sim.mujoco_sim`)
    mujoco: tuple = ()

    @property
    def force_dim(self) -> int:
        return 6 if self.kind == "surface" else 3


#: the number of joints on the deepest chain from the root above which ``crba`` runs in
#: pinocchio's WORLD convention (:func:`crba_convention`)
DEEP_TREE = 16


def crba_convention(m: pin.Model) -> pin.Convention:
    """The ``crba`` convention of :func:`whole_body_terms` for model ``m``: LOCAL (pinocchio's
    default) unless its deepest chain of joints from the root is longer than
    :data:`DEEP_TREE`, then WORLD. LOCAL's cost grows with a chain's depth faster than
    WORLD's: pinocchio 4.1 and 3.8, serial chains, µs per call (LOCAL / WORLD): depth 25
    6.1 / 4.4, 49 19 / 9.4, 97 148 / 48, 157 385 / 131; Talos (depth 8), TIAGo (10), G1
    (12) take equal times, and keep LOCAL, so their M is bit for bit what it was; WORLD's M
    differs from LOCAL's by rounding (3e-16 on the 156-joint chain)."""
    depth = max((len(s) for s in m.supports), default=0) - 1      # supports[j] starts at the universe
    return pin.Convention.WORLD if depth > DEEP_TREE else pin.Convention.LOCAL


def whole_body_terms(m: pin.Model, d: pin.Data, q: np.ndarray, v: np.ndarray, zero: np.ndarray,
                     convention: pin.Convention = pin.Convention.LOCAL) -> None:
    """The pinocchio algorithms of one control cycle, once each (module docstring); ``zero``
    a zero vector of size nv (the a = 0 of the forward pass); ``convention`` crba's
    (:func:`crba_convention`)."""
    pin.forwardKinematics(m, d, q, v, zero)             # placements, velocities, a = 0 bias
    pin.computeJointJacobians(m, d)                     # from those placements
    pin.updateFramePlacements(m, d)
    pin.crba(m, d, q, convention)                       # M(q)
    pin.nonLinearEffects(m, d, q, v)                    # h(q, q̇)
    # CoM, its velocity and its drift J̇_com q̇ (the CoM acceleration of the a = 0 pass),
    # then its Jacobian, from the placements above
    pin.centerOfMass(m, d, pin.KinematicLevel.ACCELERATION, False)
    pin.jacobianCenterOfMass(m, d, False)


@dataclass
class RobotModel:
    """One robot: pinocchio model and data, named frames, contacts, limits, cache.

    Built by :func:`wbc.load_robot` from a robot YAML; the constructor runs one
    :meth:`update` at ``q_default``, v = 0.

    Args:
        name: the robot's name (``talos``).
        model: its pinocchio model (locked joints already removed).
        root: ``"free_flyer"`` (6 unactuated velocity coordinates), ``"planar"`` (3: x, y,
            yaw) or ``"fixed"``.
        actuated_root: whether the root's coordinates are actuated (a driven mobile base);
            False for a free flyer.
        frames: frame alias (``right_hand``) -> URDF frame name.
        contacts: contact name (``left_foot``) -> its :class:`ContactSurface`.
        q_default: the default configuration (nq; m, rad, unit quaternion).
        q_min: lower joint position limits (nq; m, rad; −inf: none).
        q_max: upper joint position limits (nq; m, rad; +inf: none).
        v_max: joint velocity limits (nv; m/s, rad/s).
        tau_max: actuator limits τ_max (nv; N·m, N; the controller saturates at ±τ_max).
        differential_drive: the planar base rolls on wheels (no sideways motion: the
            controller adds :class:`~wbc.tasks.DifferentialDrive`); default False.
        default_gains: task name or kind -> default kp (1/s²) of a task built without one
            (:mod:`wbc.robot.gains`); default none.
        urdf_path: the URDF file it was built from; None: not from a file.
        package_dirs: folders that resolve the URDF's ``package://`` meshes; default none.
        locked_joints: URDF joints fixed at their default position and removed from the
            model; default none.
        source: the robot YAML file it was loaded from; None: built in Python.
        compensation: joint damping and friction D q̇ + F σ(q̇) added to h (robot YAML
            ``compensate:``, :mod:`wbc.robot.joint_compensation`); None: none.
        position_gains: the position servos' gains (robot YAML ``position_gains:``,
            :func:`wbc.robot.servo.servo_gains`); default none given (derived from the robot).
    """

    name: str
    model: pin.Model
    root: str
    actuated_root: bool
    frames: dict[str, str]
    contacts: dict[str, ContactSurface]
    q_default: np.ndarray
    q_min: np.ndarray
    q_max: np.ndarray
    v_max: np.ndarray
    tau_max: np.ndarray
    differential_drive: bool = False
    default_gains: dict[str, float] = field(default_factory=dict)
    urdf_path: Path | None = None
    package_dirs: list[str] = field(default_factory=list)
    locked_joints: list[str] = field(default_factory=list)
    source: Path | None = None
    #: D q̇ + F σ(q̇) added to h (robot YAML ``compensate:``), None for none
    compensation: JointCompensation | None = None
    #: the position servos' gains of the robot YAML (``position_gains:``, :mod:`wbc.robot.servo`):
    #: ``kp``/``kd`` {velocity index: gain} and ``saturation_error`` (rad or m); empty: defaults
    position_gains: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        m = self.model
        self.data = m.createData()
        self.nq, self.nv = m.nq, m.nv
        self.n_root = {"free_flyer": 6, "planar": 3, "fixed": 0}[self.root]
        actuated = np.ones(self.nv, dtype=bool)
        if not self.actuated_root:
            actuated[: self.n_root] = False
        self.actuated_mask = actuated
        self.actuated_idx = np.flatnonzero(actuated)
        self.unactuated_idx = np.flatnonzero(~actuated)
        self.na = int(actuated.sum())
        # Joint coordinates a posture task drives: everything but the root.
        self.joint_idx = np.arange(self.n_root, self.nv)
        self._frame_ids: dict[str, int] = {}
        self._cache: dict[tuple, np.ndarray] = {}
        self._velocity_units: tuple[str, ...] | None = None
        self._views = HeldViews(None)             # pinocchio's arrays as held views (frame_arrays, com ...)
        self.q = self.q_default.copy()
        self.v = np.zeros(self.nv)
        self._zero_v = np.zeros(self.nv)
        #: the convention :meth:`update` runs ``crba`` in (:func:`crba_convention`)
        self.crba_convention = crba_convention(m)
        self._h_eff = None          # h + the compensation, when there is one
        #: the known external generalised force τ_e (nv, N·m or N, applied *to* the robot) of
        #: the last ``update``, already subtracted from ``h``; zeros when none was given
        self.external_torque = np.zeros(self.nv)
        self._external = False      # whether the last update had one (external_torque ≠ 0 then)
        self.cycle = 0
        self.update(self.q, self.v)

    def __getstate__(self) -> dict:
        """Pickled or copied without the held views (:mod:`wbc.robot.held_views`)."""
        state = self.__dict__.copy()
        state["_views"] = HeldViews(None)
        return state

    # ------------------------------------------------------------------ frames
    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of a frame alias (``right_hand``) or URDF frame name.

        Args:
            name: a frame alias of ``frames`` or a URDF frame name; neither is a
                FrameNotFound listing the aliases.
        """
        fid = self._frame_ids.get(name)
        if fid is not None:
            return fid
        urdf_name = self.frames.get(name, name)
        if not self.model.existFrame(urdf_name):
            some = ", ".join(sorted(self.frames))
            raise FrameNotFound(
                f"robot '{self.name}' has no frame '{name}': expected one of its named frames "
                f"[{some}] or a URDF frame name (e.g. {self.model.frames[len(self.model.frames) - 1].name})"
            )
        fid = self.model.getFrameId(urdf_name)
        self._frame_ids[name] = fid
        return fid

    def contact(self, name: str) -> ContactSurface:
        """The contact surface named ``name`` (``left_foot``) of ``contacts``.

        Args:
            name: a contact name; one the robot does not define is a FrameNotFound (listing
                its frames if ``name`` is no frame either, else its contacts).
        """
        if name in self.contacts:
            return self.contacts[name]
        self.frame_id(name)  # raises FrameNotFound with the list of frames
        raise FrameNotFound(
            f"robot '{self.name}' defines no contact surface '{name}': expected one of "
            f"{sorted(self.contacts)} (add it under 'contacts:' in the robot YAML)"
        )

    # ------------------------------------------------------------------ state
    def check_state(self, q: np.ndarray, v: np.ndarray, finite: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) as flat float arrays of sizes (nq, nv), else TargetError.

        Args:
            q: a configuration (nq; m, rad, unit quaternion).
            v: a velocity (nv; m/s, rad/s).
            finite: True (default): a NaN or inf is a TargetError too; the controller passes
                False (its fault monitor has checked that already, :mod:`wbc.controller.faults`).
        """
        if not (type(q) is np.ndarray is type(v) and q.dtype == v.dtype == float and q.ndim == v.ndim == 1):
            q, v = np.asarray(q, dtype=float).reshape(-1), np.asarray(v, dtype=float).reshape(-1)
        if q.shape != (self.nq,) or v.shape != (self.nv,):
            raise TargetError(
                f"robot '{self.name}': expected q of shape ({self.nq},) and v of shape ({self.nv},), "
                f"got {q.shape} and {v.shape}"
            )
        # a sum is finite iff every term is (one reduction instead of two isfinite passes);
        # a sum that overflows is checked term by term
        if finite and not math.isfinite(q.sum() + v.sum()) and not (np.isfinite(q).all() and np.isfinite(v).all()):
            raise TargetError(f"robot '{self.name}': q or v contains NaN or inf")
        return q, v

    def update(self, q: np.ndarray, v: np.ndarray, external_torque: np.ndarray | None = None) -> None:
        """Run the cycle's pinocchio algorithms once (see the module docstring).

        Args:
            q: the configuration (nq; m, rad, unit quaternion), not copied.
            v: the velocity (nv; m/s, rad/s), not copied.
            external_torque: a known external generalised force τ_e on the robot (nv; N·m,
                N on linear root rows), moved into h = C q̇ + g − τ_e for this cycle; None:
                none. Of another size or not finite, a TargetError.
        """
        self.q, self.v = q, v
        whole_body_terms(self.model, self.data, q, v, self._zero_v, self.crba_convention)
        if external_torque is None:
            if self._external:
                self.external_torque = np.zeros(self.nv)
                self._external = False
        else:
            tau_e = np.asarray(external_torque, dtype=float)
            if tau_e.shape != (self.nv,) or not np.all(np.isfinite(tau_e)):
                raise TargetError(f"robot '{self.name}': external_torque must be {self.nv} finite numbers, "
                                  f"got shape {tau_e.shape}")
            self.external_torque = tau_e.copy()
            self._external = True
            self.data.nle -= tau_e
        if self.compensation is not None:
            self._h_eff = self.data.nle + self.compensation.torque(v)
        self._cache.clear()
        self.cycle += 1

    def update_kinematics(self, q: np.ndarray, v: np.ndarray | None = None) -> None:
        """The velocity-level cycle's pinocchio calls, once (:mod:`wbc.controller.velocity`):
        ``jacobianCenterOfMass(q)`` (the joint placements, the joint Jacobians ``data.J`` as
        ``computeJointJacobians(q)`` gives them, bit for bit: ``tests/robot/test_update_kinematics.py``;
        the CoM, J_com), then the frame placements: ``data.J`` written once, not twice. No M, h, body
        velocities or drifts: after it, ``M``, ``h``, ``com_velocity``, ``com_drift``, ``frame_velocity``
        and ``frame_drift`` hold the last :meth:`update`'s values, not this state's.

        Args:
            q: the configuration (nq; m, rad, unit quaternion), not copied.
            v: the velocity kept as ``v`` (nv; m/s, rad/s); None: zeros.
        """
        m, d = self.model, self.data
        self.q = q
        self.v = self._zero_v if v is None else v
        pin.jacobianCenterOfMass(m, d, q, False)
        pin.updateFramePlacements(m, d)
        self._cache.clear()
        self.cycle += 1

    # ---------------------------------------------------------- cached terms
    @property
    def M(self) -> np.ndarray:
        """Joint-space inertia matrix M(q) (the chapter's B(q)), nv × nv, kg·m²."""
        return self._held().M

    @property
    def h(self) -> np.ndarray:
        """Nonlinear effects h = C(q, q̇)q̇ + g(q) − τ_e (τ_e the known external generalised
        force given to :meth:`update`, else 0), plus D q̇ + F σ(q̇) with a ``compensation``
        (:mod:`wbc.robot.joint_compensation`); nv, N·m."""
        return self._held().nle if self.compensation is None else self._h_eff  # type: ignore[return-value]  # update() sets it

    def _held(self) -> HeldViews:
        views = self._views
        if views.data is not self.data:
            views = self._views = HeldViews(self.data)
        return views

    @property
    def com(self) -> np.ndarray:
        """Centre of mass in the world frame (3, m)."""
        return self._held().com

    @property
    def com_velocity(self) -> np.ndarray:
        """Centre-of-mass velocity in the world frame (3, m/s)."""
        return self._held().vcom

    @property
    def com_jacobian(self) -> np.ndarray:
        """CoM Jacobian J_com (3 × nv): ṗ_com = J_com q̇."""
        return self._held().Jcom

    @property
    def com_drift(self) -> np.ndarray:
        """J̇_com q̇ in m/s²."""
        return self._held().acom

    @property
    def mass(self) -> float:
        """Total mass (kg)."""
        return float(self.data.mass[0])

    @property
    def gravity(self) -> float:
        """|g| (m/s²), the model's gravity (``model.gravity``), not an assumed 9.81."""
        return float(np.linalg.norm(self.model.gravity.linear))

    @property
    def weight(self) -> float:
        """m |g| (N): what the contacts carry at rest."""
        return self.mass * self.gravity

    def frame_placement(self, fid: int) -> pin.SE3:
        """The frame's world placement (SE3; m), of this cycle's :meth:`update`.

        Args:
            fid: pinocchio frame index (:meth:`frame_id`).
        """
        return self.data.oMf[fid]

    def frame_arrays(self, fid: int) -> FrameArrays:
        """Pinocchio's arrays a compiled frame row reads (:class:`FrameArrays`): views, held per
        frame (and per ``data`` object), that :meth:`update` refreshes in place.

        Args:
            fid: pinocchio frame index (:meth:`frame_id`).
        """
        return self._held().frame(self.model, fid)

    @property
    def joint_jacobians(self) -> np.ndarray:
        """Pinocchio's ``data.J`` (6 × nv): every joint's Jacobian, world frame at the world
        origin (linear rows first), as :meth:`update` leaves it; a view held once."""
        return self._held().J

    def frame_jacobian(self, fid: int, ref: pin.ReferenceFrame = WORLD_ALIGNED) -> np.ndarray:
        """6 × nv frame Jacobian (linear rows first) in ``ref``; extracted once per cycle.

        Args:
            fid: pinocchio frame index (:meth:`frame_id`).
            ref: pinocchio reference frame; default ``LOCAL_WORLD_ALIGNED`` (at the frame's
                origin, world axes), or ``LOCAL``, ``WORLD``.
        """
        key = ("J", fid, ref)
        J = self._cache.get(key)
        if J is None:
            J = pin.getFrameJacobian(self.model, self.data, fid, ref)
            self._cache[key] = J
        return J

    def frame_velocity(self, fid: int, ref: pin.ReferenceFrame = WORLD_ALIGNED) -> np.ndarray:
        """The frame's spatial velocity (6: linear m/s first, angular rad/s) in ``ref``.

        Args:
            fid: pinocchio frame index (:meth:`frame_id`).
            ref: pinocchio reference frame; default ``LOCAL_WORLD_ALIGNED``.
        """
        key = ("v", fid, ref)
        vel = self._cache.get(key)
        if vel is None:
            vel = pin.getFrameVelocity(self.model, self.data, fid, ref).vector
            self._cache[key] = vel
        return vel

    def frame_drift(self, fid: int, ref: pin.ReferenceFrame = WORLD_ALIGNED, classical: bool = True) -> np.ndarray:
        """J̇q̇ of a frame: its acceleration at q̈ = 0 (m/s², rad/s²).

        Args:
            fid: pinocchio frame index (:meth:`frame_id`).
            ref: pinocchio reference frame; default ``LOCAL_WORLD_ALIGNED``.
            classical: True (default): the time derivative of the origin's velocity (what a
                point or pose task needs); False: the spatial acceleration (what a rigid 6-D
                contact needs).
        """
        key = ("a", fid, ref, classical)
        a = self._cache.get(key)
        if a is None:
            fn = pin.getFrameClassicalAcceleration if classical else pin.getFrameAcceleration
            a = fn(self.model, self.data, fid, ref).vector
            self._cache[key] = a
        return a

    # ---------------------------------------------------------- conveniences
    def velocity_units(self) -> tuple[str, ...]:
        """The unit of each velocity coordinate's displacement: ``"m"`` for the root's translation
        and prismatic joints, ``"rad"`` for rotations (revolute, continuous, spherical, the root's
        rotation); length nv."""
        got = self._velocity_units
        if got is None:
            units: list[str] = []
            for j in self.model.joints[1:]:
                kind = j.shortname()
                if kind == "JointModelFreeFlyer":
                    units += ["m"] * 3 + ["rad"] * 3
                elif kind == "JointModelPlanar":
                    units += ["m", "m", "rad"]
                elif "Prismatic" in kind or kind.startswith("JointModelP"):
                    units += ["m"] * j.nv
                else:
                    units += ["rad"] * j.nv
            got = self._velocity_units = tuple(units)
        return got

    def difference(self, q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
        """Tangent vector (nv; m, rad) that moves q_from to q_to on the configuration manifold.

        Args:
            q_from: start configuration (nq).
            q_to: end configuration (nq).
        """
        return pin.difference(self.model, q_from, q_to)

    def integrate(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """The configuration q ⊕ dq (nq) on the configuration manifold (``pin.integrate``).

        Args:
            q: a configuration (nq).
            dq: a tangent displacement (nv; m, rad), e.g. v·dt.
        """
        return pin.integrate(self.model, q, dq)

    def random_configuration(self, rng: np.random.Generator, margin: float = 0.1) -> np.ndarray:
        """A random configuration inside the joint limits; joints without finite limits (and
        the root) keep ``q_default``.

        Args:
            rng: the random generator (``np.random.default_rng(seed)``).
            margin: fraction of each joint's range kept clear at both ends (unitless, in
                [0, 0.5)); default 0.1.
        """
        lo, hi = self.q_min.copy(), self.q_max.copy()
        finite = np.isfinite(lo) & np.isfinite(hi) & (hi - lo < 1e3)
        span = hi - lo
        q = self.q_default.copy()
        u = rng.uniform(size=self.nq)
        q[finite] = lo[finite] + span[finite] * (margin + (1 - 2 * margin) * u[finite])
        return q

    def __repr__(self) -> str:
        return f"RobotModel('{self.name}', nq={self.nq}, nv={self.nv}, root={self.root})"
