"""Time-stepping rigid-body simulation with unilateral Coulomb contacts, on pinocchio.

Model: velocity-level (impulse-based) time stepping, the scheme of most robotics
simulators. Each step of length h:

1. free motion:  v_free = v + h · ABA(q, v, τ, f_ext)            (pinocchio ``aba``)
2. contacts: every robot contact point p_i within ``margin`` of a surface gets a
   contact frame (z the surface normal) and its 3 × nv Jacobian J_i. With the
   Delassus matrix G = J M⁻¹ Jᵀ (``computeMinverse``) and g = J v_free, find the
   impulses λ_i in the Coulomb cones ‖λ_t‖ ≤ μ λ_n such that the contact
   velocities σ = G λ + g are complementary to them (no pulling, no
   penetration, sliding opposes the impulse): projected Gauss-Seidel, by default
   pinocchio 4's rule compiled (:mod:`wbc.sim.pgs`), or pinocchio's own binding
   (``contact_solver="pinocchio"``: ``PGSContactSolver`` on pinocchio 3,
   ``PGSConstraintSolver`` on pinocchio 4; :mod:`wbc.sim.contact_solver`). The rows,
   G and g are compiled too (:mod:`wbc.sim.contact_rows`).
   The normal rows carry a Baumgarte term (−β·depth/h for a penetrating point,
   +gap/h for one about to touch) that removes penetration without bouncing.
3. v⁺ = v_free + M⁻¹ Jᵀ λ,  q⁺ = q ⊕ h v⁺ (``integrate`` on the manifold).

Why this model: contacts are rigid (no stiffness to tune, no penetration at
rest beyond the Baumgarte residue), sticking contacts do not creep (the
tangential velocity is driven to zero, not to a spring equilibrium), sliding
obeys Coulomb's law exactly (a box on an incline slides iff tan θ > μ), and
the impact is perfectly inelastic, so nothing rebounds higher than it fell.

A differential-drive base (planar root) adds the bilateral constraint of zero
lateral base velocity, solved in the same Gauss-Seidel sweep.

Joint damping and dry friction from the URDF (``joint_dynamics=True``): implicit damping and
friction impulses bounded by the URDF's friction, in the same step (:mod:`wbc.sim.joint_dynamics`).

An optional motor driver saturates the torques: τ_i is clipped to ±``tau_limits``_i
(N·m) before it is applied, and ``saturated_steps`` counts the control periods in
which that changed anything.

The simulator owns its own pinocchio Data: it never shares state with a
controller. What a controller may read is :meth:`measure` (q, v with optional
noise and latency) and :meth:`contact_wrench` (what a foot force sensor reads).
"""

from __future__ import annotations

from collections import deque

import numpy as np
import pinocchio as pin

from ..errors import WbcError
from . import contact_rows as cr
from .bodies import Push, contact_points, dynamics_model, full_limits
from .contact_solver import ContactSolver, solver_class
from .joint_dynamics import JointDynamics, eliminate_lateral
from .options import SimOptions

#: the contact step's PGS: at most this many sweeps per step ...
PGS_MAX_ITERATIONS = 300
#: ... or until its feasibility and complementarity residuals are below the absolute
#: precision (N·s) or the relative one (unitless; pinocchio's PGS criteria, wbc.sim.contact_solver)
PGS_ABSOLUTE_PRECISION = 1e-10
PGS_RELATIVE_PRECISION = 1e-12
#: default contact position correction per step (Baumgarte), unitless
BAUMGARTE = 0.2
#: default contact detection margin, m
CONTACT_MARGIN = 2e-3


class Simulator:
    """See the module docstring. Units: s, m, rad, N, N·m.

    The constructor takes the model, the contact points, the environment and the initial
    state; every setting (``dt``, ``substeps``, ``tau_limits``, ``joint_dynamics``,
    ``contact_solver``, …) is a field of :class:`~wbc.sim.options.SimOptions`, given as
    ``options=`` or one by one as keywords (each field's meaning and unit are in its docstring).
    """

    def __init__(self, model: pin.Model, points, environment, q0, v0=None, options: SimOptions | None = None,
                 **settings) -> None:
        """Args:
            model: the simulated robot's pinocchio model.
            points: contact points, ``(joint name, position in that joint's frame, m)``.
            environment: shapes of :mod:`wbc.sim.environment`.
            q0: initial configuration (nq).
            v0: initial velocity (nv, rad/s or m/s); None: zero.
            options: :class:`~wbc.sim.options.SimOptions` (the MuJoCo-only fields unused).
            **settings: its fields one by one, over ``options``.
        """
        o = self.options = SimOptions.of(options, settings, "Simulator")
        dt, substeps, actuated, contact_solver = o.dt, o.substeps, o.actuated, o.contact_solver
        self.model = model
        self.data = model.createData()
        # M⁻¹ and ABA on a joints-only copy of the model and its own data (bodies.dynamics_model:
        # the same numbers; pinocchio 3's bindings copy the model they are given at each call)
        self._dyn_model = dynamics_model(model)
        self._dyn_data = self._dyn_model.createData()
        # the contact surfaces (obstacles, wbc.sim.environment.Sphere/Cylinder, touch no contact point)
        self.env = [e for e in environment if getattr(e, "contact_surface", True)]
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.h = self.dt / self.substeps
        self.q = np.array(q0, dtype=float)
        self._kin_q: bytes | None = None           # the q (its bytes) data's kinematics and CoM are at (_kinematics)
        self.v = np.zeros(model.nv) if v0 is None else np.array(v0, dtype=float)
        self.t = 0.0
        self.actuated = np.ones(model.nv, bool) if actuated is None else np.asarray(actuated, bool)
        self.differential_drive = o.differential_drive
        self.baumgarte = BAUMGARTE if o.baumgarte is None else o.baumgarte
        self.margin = CONTACT_MARGIN if o.margin is None else o.margin
        # PGS under-relaxation: with the default step, a friction block whose Delassus
        # eigenvalue ratio exceeds 2 (a box turned about the vertical) overshoots and
        # the resting body rattles; 0.6 converges on every case tested
        self.over_relax = 0.6
        self.points = [(model.getJointId(j), np.asarray(r, float)) for j, r in points]
        self._solver_class = solver_class(contact_solver)
        self._pgs: dict[tuple, ContactSolver] = {}   # one solver per tuple of friction coefficients
        # the points as arrays for the compiled rows: each point's joint slot and offset, the
        # joints' placements (refilled each step) and supporting dofs
        self._joints = sorted({j for j, _ in self.points})
        self._slot = np.array([self._joints.index(j) for j, _ in self.points], dtype=np.int64)
        self._offsets = np.array([r for _, r in self.points], dtype=float).reshape(-1, 3)
        self._support = cr.supports(model, self._joints)
        # the contact joints' placements in data.oMi as views taken once (R and t of each, on the
        # data's memory, which forward kinematics refreshes in place): the compiled calls read them
        # directly, with no crossing of the bindings per step (a fresh data.oMi[j] costs a proxy
        # and its registration, its .homogeneous a 4 × 4 array); a dummy pair when no point
        self._rot = tuple(self.data.oMi[j].rotation for j in self._joints) or (np.zeros((3, 3), order="F"),)
        self._trans = tuple(self.data.oMi[j].translation for j in self._joints) or (np.zeros(3),)
        # data.J as a view on the data's memory, taken once (each read of the attribute is a binding
        # crossing): allocated with the data, never resized, it lives as long as the simulator's data
        Jw = self.data.J
        self._Jw = Jw.reshape(6, 1) if Jw.ndim == 1 else Jw     # (eigenpy hands 6 × 1 over as a vector)
        self._P = np.zeros((len(self.points), 3))
        self._com = self.data.com[0]       # a view on the data's CoM (centerOfMass refreshes it in place)
        npts = len(self.points)
        self._shapes = cr.shape_table(self.env)    # None: a shape the compiled search does not know
        self._ids, self._shape_of = np.zeros(npts, dtype=np.int64), np.zeros(npts, dtype=np.int64)
        self._depths, self._frames = np.zeros(npts), np.zeros((npts, 3, 3))
        self._J = np.zeros((3 * npts, model.nv))
        # find_contacts's argument groups (the arrays are refilled in place)
        self._point_args = (self._rot, self._trans, self._slot, self._offsets, self._support)
        self._contact_out = (self._P, self._ids, self._shape_of, self._depths, self._frames, self._J)
        self._shape_args = None if self._shapes is None else self._shapes[:5]
        # contact_motion's buffers (the contacts find_contacts writes, the shapes' μ) and the
        # rotation it is given when the root is not a free flyer (unused then)
        self._motion_args = None if self._shapes is None else (self._J, self._depths, self._frames, self._ids,
                                                               self._shape_of, self._shapes[5])
        self._no_rotation, self._w = np.eye(3), np.zeros(3)
        self._tau = np.zeros(model.nv)             # the driver's torque of the current step
        self._fused = contact_solver == "compiled"   # the contact step in one compiled call
        self._one_call = self._fused    # and, where it applies, the whole step after the search (contact_motion)
        self.pgs_sweeps = 0         # the last contact solve's sweeps (compiled PGS)
        self.pushes: list[Push] = []
        self.point_forces = np.zeros((len(self.points), 3))   # world frame, N, last step
        self._warm = np.zeros((len(self.points), 3))          # last step's impulses, N·s, contact frames
        self._pgs_state = (self._warm, self.point_forces)
        self._rng = np.random.default_rng(o.seed)
        self.noise_q, self.noise_v = o.noise_q, o.noise_v
        self._delay: deque = deque(maxlen=o.latency_steps + 1)
        self.solver_failures = 0
        self._free_flyer = model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer"
        self.tau_limits = full_limits(o.tau_limits, self.actuated)
        self._no_limits = np.empty(0)
        self.saturated_steps = 0    # control periods in which the driver clipped τ
        self.joint_dynamics = JointDynamics.of_model(model) if o.joint_dynamics else None

    # ----------------------------------------------------------- construction
    @classmethod
    def for_robot(cls, robot, environment, q0=None, extra_points=(), options: SimOptions | None = None,
                  v0=None, **settings) -> Simulator:
        """A simulator of ``robot`` (a :class:`~wbc.robot.model.RobotModel`): sole corners of its
        contact surfaces and the origins of its point contacts touch the environment;
        ``extra_points``: more ``(frame name, offset in the frame)``; ``options`` and
        ``settings`` as the constructor's (``actuated``, ``differential_drive``: the robot's)."""
        pts = [(joint, offset) for joint, offset, *_ in contact_points(robot, extra_points)]
        q0 = robot.q_default if q0 is None else q0
        o = SimOptions.of(options, {"actuated": robot.actuated_mask,
                                    "differential_drive": robot.differential_drive, **settings}, "Simulator")
        return cls(robot.model, pts, environment, q0, v0, o)

    def push(self, frame: str, force, start: float, duration: float) -> None:
        """Schedule an external force (N, world) on ``frame`` (a model frame name)."""
        if not self.model.existFrame(frame):
            raise WbcError(f"simulator: no frame '{frame}' to push")
        self.pushes.append(Push(frame, np.asarray(force, float), float(start), float(duration)))

    # ----------------------------------------------------------- stepping
    def step(self, tau: np.ndarray) -> None:
        """Advance one control period with joint torques ``tau`` (N·m; nv, or na actuated),
        clipped to ±``tau_limits`` as a motor driver would."""
        tau = np.asarray(tau, dtype=float)
        if tau.shape[0] != self.model.nv:
            full = np.zeros(self.model.nv)
            full[self.actuated] = tau
            tau = full
        lim = self.tau_limits
        # a fresh array per step: the caller may keep the torque it was given
        out = np.empty(self.model.nv)
        finite, clipped = cr.driver_torque(tau, self.actuated, self._no_limits if lim is None else lim, out)
        if not finite:
            raise WbcError("simulator: non-finite torque")
        tau = out
        self.saturated_steps += clipped
        for _ in range(self.substeps):
            self._substep(tau)

    def step_position(self, q_cmd: np.ndarray, v_cmd: np.ndarray, kp: np.ndarray, kd: np.ndarray,
                      tau_ff: np.ndarray | None = None) -> None:
        """Advance one control period with position-controlled actuators: at every physics step
        τ = τ_ff + k_p (q_cmd ⊖ q) + k_d (q̇_cmd − q̇) on the actuated coordinates
        (:func:`wbc.robot.servo.servo_torque`), clipped to ±``tau_limits``.

        Args:
            q_cmd: commanded configuration (nq).
            v_cmd: commanded velocity (nv; m/s, rad/s).
            kp: servo stiffnesses (nv; N·m/rad, N/m).
            kd: servo dampings (nv; N·m·s/rad, N·s/m).
            tau_ff: feed-forward torque held over the period (nv; N·m, N); None: none.
        """
        from wbc.robot.servo import servo_torque

        lim = self.tau_limits
        clipped = False
        for _ in range(self.substeps):
            tau = np.where(self.actuated, servo_torque(self.model, self.q, self.v, q_cmd, v_cmd, kp, kd, tau_ff),
                           0.0)
            if not np.all(np.isfinite(tau)):
                raise WbcError("simulator: non-finite servo torque")
            if lim is not None and np.any(np.abs(tau) > lim):
                tau = np.clip(tau, -lim, lim)
                clipped = True
            self._substep(tau)
        self.saturated_steps += clipped

    def _external_forces(self):
        active = [p for p in self.pushes if p.active(self.t)]
        if not active:
            return None
        m, d = self.model, self.data
        fext = [pin.Force.Zero() for _ in range(m.njoints)]
        for p in active:
            fid = m.getFrameId(p.frame)
            j = m.frames[fid].parentJoint
            pw = d.oMf[fid].translation
            fext[j] += d.oMi[j].actInv(pin.Force(p.force, np.cross(pw, p.force)))
        return fext

    def _substep(self, tau: np.ndarray) -> None:
        m, d, h = self.model, self.data, self.h
        q, v = self.q, self.v
        if self._kin_q is not None and self._kin_q == q.tobytes():
            # data's joint placements are at q already (_kinematics, for the metrics read after the
            # last step): the Jacobians from them, the same products without forward kinematics again
            pin.computeJointJacobians(m, d)
        else:
            pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        fext = self._external_forces() if self.pushes else None
        k = None
        if fext is None and self._one_call and self._shapes is not None and self.joint_dynamics is None \
                and not self.differential_drive:
            k = cr.find_contacts_and_spin(self._point_args, self._shape_args, self.margin, self._Jw,
                                          self._contact_out, (v, h, self._free_flyer, self._w))
            if k:
                self._contact_motion(k, tau)
                return
        J, frames, depths, mus, ids = self._contact_rows(k)
        rows = ids.size > 0
        nh = self.differential_drive
        jd = self.joint_dynamics
        if jd is not None:          # damped: M̃⁻¹ = (M + hD)⁻¹ in the free motion and every impulse
            Minv, a_free = jd.free_motion(m, d, q, v, tau, fext, h)
            v_free, u, w = cr.free_velocity(v, a_free, h, self._free_flyer)
        else:
            Minv, v_free, u, w = self._free_motion(q, v, tau, fext, bool(rows or nh))
        if self._free_flyer:
            # The root's linear velocity is in the body frame: its rate holds the term
            # −ω × v, which explicit Euler turns into energy gain for a spinning body.
            # Integrate that rotation exactly instead: v⁺ = exp(−[ω] h)(v + h(a + ω × v)).
            v_free[:3] = pin.exp3(w) @ u            # w = −ω h

        if jd is not None and jd.friction_idx.size:
            v = self._with_joint_friction(v_free, Minv, J, frames, depths, mus, ids)
        elif rows and not nh and self._fused:
            settings = (self.baumgarte, h, self.over_relax, PGS_MAX_ITERATIONS, PGS_ABSOLUTE_PRECISION,
                        PGS_RELATIVE_PRECISION)
            v, self.pgs_sweeps, _, finite = cr.contact_step((J, depths, mus, frames, ids), Minv, v_free, settings,
                                                            self._pgs_state)
            if not finite:
                self.solver_failures += 1
        elif rows or nh:
            v_new = v_free
            if rows:
                G = cr.delassus(J, Minv)
                g = cr.contact_velocity(J, v_free, depths, self.baumgarte, h)
                lam = self._warm[ids].reshape(-1)
                solver = self._pgs_for(mus)
                if nh:
                    lam = self._solve_with_nonholonomic(G, g, J, Minv, v_free, lam, solver)
                else:
                    lam = solver.solve(G, g, lam)
                if not np.all(np.isfinite(lam)):
                    self.solver_failures += 1
                    lam = np.zeros_like(g)
                v_new = v_free + Minv @ (J.T @ lam)
                if nh:
                    v_new = self._lateral_projection(v_new, Minv)
                self._keep_impulses(lam, frames, ids)
            else:
                v_new = self._lateral_projection(v_free, Minv)
                self._keep_impulses(None, frames, ids)
            v = v_new
        else:
            v = v_free
            self._keep_impulses(None, frames, ids)
        self.v = v
        self.q = pin.integrate(m, q, v * h)
        self.t += h

    def _contact_motion(self, k: int, tau: np.ndarray) -> None:
        """The step from (q, v) with ``k`` ≥ 1 contacts found (:func:`~wbc.sim.contact_rows.find_contacts`),
        no push, no joint dynamics and no differential drive: M⁻¹ and h from pinocchio, exp₃(−ω h)
        of a free-flyer root, then the free motion, the contact step and v⁺ in one compiled call
        (:func:`~wbc.sim.contact_rows.contact_motion`: the same operations as the general path's
        calls), q⁺ = q ⊕ h v⁺."""
        m, h, q, v = self.model, self.h, self.q, self.v
        Minv = pin.computeMinverse(self._dyn_model, self._dyn_data, q)
        nle = pin.nonLinearEffects(m, self.data, q, v)
        R = pin.exp3(self._w) if self._free_flyer else self._no_rotation    # w = −ω h (find_contacts_and_spin)
        settings = (self.baumgarte, h, self.over_relax, PGS_MAX_ITERATIONS, PGS_ABSOLUTE_PRECISION,
                    PGS_RELATIVE_PRECISION, self._free_flyer)
        v, dq, self.pgs_sweeps, finite = cr.contact_motion(k, self._motion_args, (Minv, tau, nle, v, R), settings,
                                                           self._pgs_state)
        if not finite:
            self.solver_failures += 1
        self.v = v
        self.q = pin.integrate(m, q, dq)
        self.t += h

    def _free_motion(self, q, v, tau, fext, need_minv: bool):
        """(M⁻¹ or None, and :func:`~wbc.sim.contact_rows.free_velocity`'s (v_free, u, w) of the free
        acceleration ABA(q, v, τ, f_ext))."""
        dm, dd = self._dyn_model, self._dyn_data
        Minv = None
        if need_minv:
            # M⁻¹ is needed for the contact impulses anyway: then the free acceleration is
            # M⁻¹(τ − h) (one matrix-vector product) rather than a second pass of ABA
            Minv = pin.computeMinverse(dm, dd, q)
        if Minv is not None and fext:
            cr.symmetrise_upper(Minv)                    # computeMinverse fills the upper triangle
        h, ff = self.h, self._free_flyer
        if Minv is None or fext:
            a_free = pin.aba(dm, dd, q, v, tau, fext) if fext else pin.aba(dm, dd, q, v, tau)
            return (Minv, *cr.free_velocity(v, a_free, h, ff))
        return (Minv, *cr.free_motion(Minv, tau, pin.nonLinearEffects(self.model, self.data, q, v), v, h, ff))

    def _keep_impulses(self, lam, frames, ids) -> None:
        """The step's impulses ``lam`` (3k, N·s, contact frames; None: no contact) kept as the next
        step's warm start, per point, and as each point's force (N, world)."""
        self._warm[:] = 0.0
        if lam is None:
            self.point_forces[:] = 0.0
            return
        self._warm[ids] = lam.reshape(-1, 3)
        cr.point_forces(frames, lam, ids, self.h, self.point_forces)

    def _with_joint_friction(self, v_free, Minv, J, frames, depths, mus, ids) -> np.ndarray:
        """The velocity after the joint friction impulses, the contact impulses and the
        differential drive's lateral constraint (eliminated first), as
        :meth:`JointDynamics.friction_impulses` solves them; sets the contacts' forces."""
        jd = self.joint_dynamics
        assert jd is not None, "called only with joint dynamics"
        if self.differential_drive:
            Minv, v_free = eliminate_lateral(Minv, v_free, 1)
        if not ids.size:
            self._keep_impulses(None, frames, ids)
            return jd.friction_impulses(Minv, v_free, self.h)[0]
        g = cr.contact_velocity(J, v_free, depths, self.baumgarte, self.h)
        lam = self._warm[ids].reshape(-1)
        v_new, lam = jd.friction_impulses(Minv, v_free, self.h, (J, g, self._pgs_for(mus).solve, lam))
        if not np.all(np.isfinite(lam)):
            self.solver_failures += 1
            self.point_forces[:] = 0.0          # (the warm start stays the last good step's)
            return jd.friction_impulses(Minv, v_free, self.h)[0]
        self._keep_impulses(lam, frames, ids)
        return v_new

    def _point_positions(self) -> np.ndarray:
        """World positions (m) of the contact points from the joints' placements in ``data``
        (kept in a buffer: copy it to keep it)."""
        cr.point_positions(self._rot, self._trans, self._slot, self._offsets, self._P)
        return self._P

    def _contact_rows(self, k: int | None = None):
        """Points in (or within ``margin`` of) contact, each with the surface it touches
        (the deepest; the first listed of equally deep ones): the rows of their velocity
        Jacobians in the contact frames (t1, t2, n) (3k × nv), the frames (k × 3 × 3), the
        depths (k, m), μ (k) and the points' indices (k); views of buffers the next call refills.
        ``k``: the count of a :func:`~wbc.sim.contact_rows.find_contacts` just run (its buffers
        hold the contacts then), None: search."""
        Jw = self._Jw
        if self._shapes is not None:
            shape_mu = self._shapes[5]
            if k is None:
                k = cr.find_contacts(self._point_args, self._shape_args, self.margin, Jw, self._contact_out)
            return self._J[:3 * k], self._frames[:k], self._depths[:k], shape_mu[self._shape_of[:k]], self._ids[:k]
        P = self._point_positions()
        best = np.full(P.shape[0], -1)
        dep = np.full(P.shape[0], -self.margin)
        for k, s in enumerate(self.env):
            ds = s.depths(P)
            deeper = ds > dep
            best[deeper], dep[deeper] = k, ds[deeper]
        ids = np.flatnonzero(best >= 0)
        frames = np.array([self.env[best[i]].R for i in ids]).reshape(-1, 3, 3)
        mus = np.array([self.env[best[i]].mu for i in ids])
        J = np.empty((3 * ids.size, self.model.nv))
        cr.contact_jacobian(Jw, P, ids, self._slot, self._support, frames, J)
        return J, frames, dep[ids], mus, ids

    def _pgs_for(self, mus) -> ContactSolver:
        """The PGS for this set of contacts (one μ per point), built once per tuple of μ."""
        mus = tuple(float(mu) for mu in mus)
        got = self._pgs.get(mus)
        if got is None:
            got = self._pgs[mus] = self._solver_class(mus, over_relax=self.over_relax,
                                                      max_iterations=PGS_MAX_ITERATIONS,
                                                      absolute_precision=PGS_ABSOLUTE_PRECISION,
                                                      relative_precision=PGS_RELATIVE_PRECISION)
        return got

    def _lateral_projection(self, v: np.ndarray, Minv: np.ndarray) -> np.ndarray:
        """Impulse along the base's lateral axis that zeroes its lateral velocity v[1]."""
        return v - Minv[:, 1] * (v[1] / Minv[1, 1])

    def _solve_with_nonholonomic(self, G, g, J, Minv, v_free, lam, solver: ContactSolver):
        """Contacts and the zero-lateral-velocity constraint by block Gauss-Seidel: the
        lateral impulse for the current contact impulses (its velocity change ``shift``
        enters the contacts' free velocity g + J shift), then the contacts, 5 sweeps."""
        for _ in range(5):
            v_c = v_free + Minv @ (J.T @ lam)
            shift = self._lateral_projection(v_c, Minv) - v_c
            lam = solver.solve(G, g + J @ shift, lam)
        return lam

    # ----------------------------------------------------------- sensing
    def measure(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) as a robot's encoders/IMU would give them: optional Gaussian noise
        (``noise_q`` rad or m, ``noise_v`` rad/s or m/s) and ``latency_steps`` delay."""
        q = self.q.copy()
        v = self.v.copy()
        if self.noise_q:
            dq = self._rng.normal(0.0, self.noise_q, self.model.nv)
            q = pin.integrate(self.model, q, dq)
        if self.noise_v:
            v = v + self._rng.normal(0.0, self.noise_v, self.model.nv)
        self._delay.append((q, v))
        return self._delay[0]

    def contact_wrench(self, frame: str) -> np.ndarray:
        """Wrench (f, τ) in the frame ``frame`` (N, N·m) of the contact forces on the
        points of that frame's joint: what a 6-axis force sensor there reads. f_F = Rᵀ f with R the
        frame's orientation where the step solved the forces (its start, ``data.oMf``), τ = Σ p_F × f_F
        about each point's fixed offset p_F = ʲM_f⁻¹ r (never ``data.oMi``: a read of the points moves it)."""
        m, d = self.model, self.data
        fid = m.getFrameId(frame)
        jid = m.frames[fid].parentJoint
        jMf = m.frames[fid].placement
        Rt = d.oMf[fid].rotation.T
        w = np.zeros(6)
        for (j, r), f in zip(self.points, self.point_forces):
            if j != jid or not f.any():
                continue
            fl = Rt @ f
            w[:3] += fl
            w[3:] += np.cross(jMf.actInv(r), fl)
        return w

    def _kinematics(self) -> None:
        """``data.oMi`` and ``data.com[0]`` at ``q``, once per state: ``pin.centerOfMass(model, data, q)``
        runs forward kinematics too. The state is known by ``q``'s bytes (~0.2 µs), not by the array's
        identity, so a ``q`` written in place (``sim.q[2] += 0.1``) is computed again, never read stale."""
        key = self.q.tobytes()
        if self._kin_q != key:
            pin.centerOfMass(self.model, self.data, self.q)
            self._kin_q = key

    def point_positions(self) -> np.ndarray:
        """World positions (m) of the contact points at the current state."""
        self._kinematics()
        return self._point_positions().copy()

    def com(self) -> np.ndarray:
        """World position (m) of the centre of mass at the current state."""
        self._kinematics()
        return self._com.copy()

    def energy(self) -> float:
        """Kinetic + gravitational potential energy (J)."""
        m, d = self.model, self.data
        return float(pin.computeKineticEnergy(m, d, self.q, self.v) + pin.computePotentialEnergy(m, d, self.q))
