"""Every task type's rows against finite differences, at random states of Talos, G1 and TIAGo.

A task's rows are A x = b over x = (q̈, f). What A and b must be follows from the quantity the
task drives (its ``error``, a force, the equation of motion), so each row block is checked
against a numerical derivative of that quantity, computed independently of the rows:

- motion tasks (a configuration-level error e(q) = x_d − x): A's q̈ block is −∂e/∂q, by
  central differences of ``task.error`` along ``pin.integrate(q, ±ε δ_i)``; with the gains
  and the reference acceleration at zero, b is −J̇q̇, checked against the central difference
  of the task's own A(q) q̇ along q(t) = q ⊕ t q̇ (q̈ = 0 in pinocchio's tangent coordinates:
  constant v, which is what "the acceleration at q̈ = 0" means); with gains, the PD part of b
  is K_p e − K_d A q̇ (5.16 with zero references);
- velocity-level tasks (the null-space impedance's ν = Z# q̇, the differential drive's lateral
  velocity): the drift Ż# q̇ (resp. d/dt v_y) against central differences along q ⊕ t q̇;
- force tasks (rows on f only): A = ∓∂e/∂f of the task's own force error, b = its value at f = 0,
  no q̈ columns and no dependence of b on the state;
- the equation of motion (floating-base dynamics, torque limits): A (C) against central
  differences of pinocchio's RNEA τ(q, q̇, q̈) − J_fᵀ f over x, and b (lo, hi) its value at x = 0;
- joint limits: the box's unit rows against ∂q_j/∂δ of each limited joint coordinate.

Step and tolerance: central differences with ε = 1e-6 have a truncation error ε²/6 |e'''|
≈ 2e-13 (lever arms and curvatures of order 1 m, 1 rad) and a round-off error ≈ u |e| / ε
≈ 1e-16 · 1 / 1e-6 = 1e-10 (u the double precision unit round-off, |e| ≲ 1 m): 1e-6 of the
compared block's size (atol) is 10⁴ times above both and 10⁵ times below a sign error or a
missing term (order 1). The null-space terms divide by Λ_ν (condition number up to ~10³ on
Talos), whence 1e-5 there. Measured (relative to the block's largest entry, over the three
robots and seeds): ≤ 3e-10 for the frame, CoM, posture and contact rows, ≤ 1.5e-9 for the
equation of motion, 2.4e-8 for Ż# q̇.

A task type joins by one entry in :data:`CASES`; :func:`test_every_task_type_is_in_the_table`
fails for a Task subclass in :mod:`wbc.tasks` that is neither there nor in :data:`EXEMPT`.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest

import wbc
import wbc.tasks
from tests.helpers.stacks import random_state
from wbc.scenario.contacts import with_contacts
from wbc.tasks import (
    CollisionAvoidance,
    CoM,
    Contact,
    ContactRegularization,
    ContactWrench,
    DifferentialDrive,
    FloatingBaseDynamics,
    Force,
    Frame,
    JointLimits,
    NullSpaceImpedance,
    Posture,
    SingularityAvoidance,
    Task,
    TorqueLimits,
)

EPS = 1e-6
#: relative tolerance (of the compared block's largest entry) of central differences with EPS
TOL = 1e-6
#: the same for quantities through Λ_ν⁻¹ (the null-space terms)
TOL_NULL_SPACE = 1e-5
SEEDS = (0, 1, 2)
#: the random velocities' standard deviation (rad/s, m/s)
SPEED = 0.5

#: Task subclasses that are not a task type of their own, and why
EXEMPT = {
    Task: "abstract base: no rows",
    wbc.tasks.MotionTask: "abstract base of the motion tasks: no rows",
}


# ----------------------------------------------------------------- robots and stacks
@pytest.fixture(scope="module")
def robots() -> dict[str, wbc.RobotModel]:
    """Talos and G1 (floating base, sole contacts), TIAGo (planar differential-drive base) with a
    point contact ``hand_pad`` 8 cm beyond its tool flange (the ``tiago_wipe`` scenario's)."""
    tiago = with_contacts(wbc.load_robot("tiago"), {"hand_pad": {"frame": "hand", "kind": "point",
                                                                 "offset": [0.08, 0.0, 0.0], "mu": 1.0}})
    return {"talos": wbc.load_robot("talos"), "g1": wbc.load_robot("g1"), "tiago": tiago}


def contacts_of(robot: wbc.RobotModel) -> list[Contact]:
    """One contact task per contact the robot defines (the feet, TIAGo's pad)."""
    return [Contact(name, kp=0.0, kd=0.0) for name in sorted(robot.contacts)]


HAND = {"talos": "left_hand", "g1": "left_hand", "tiago": "hand"}


@dataclass
class Case:
    """One task type in the table: ``make(robot, contacts, rng)`` builds the task (the robot's
    contact tasks are in the stack with it, so the layout has their forces), ``check`` which
    finite-difference check applies, ``robots`` where it is checked."""

    make: Callable
    check: str
    robots: tuple[str, ...] = ("talos", "g1", "tiago")


def _frame(robot, contacts, rng, mask="pose"):
    """A frame task on the hand, its target the hand's orientation (the Jacobian of log₃ is the
    identity only there, :func:`test_frame_orientation_error_approximation`) and a position
    ~10 cm away."""
    t = Frame(HAND[robot.name], kp=0.0, kd=0.0, mask=mask)
    M = robot.frame_placement(robot.frame_id(t.frame))
    t.target = pin.SE3(M.rotation, M.translation + 0.1 * rng.standard_normal(3))
    return t


def _com(robot, contacts, rng, axes="xyz", per_axis=False):
    gains = [0.0] * len(axes) if per_axis else 0.0          # per-axis gains take a path of their own
    return CoM(kp=gains, kd=gains, axes=axes, target=robot.com + 0.05 * rng.standard_normal(3))


def _posture(robot, contacts, rng, joints=None):
    q = robot.random_configuration(rng, margin=0.2)
    if joints is not None:
        joints = joints(robot)
    return Posture(kp=0.0, kd=0.0, target=q, joints=joints)


def _contact(robot, contacts, rng, sliding=False):
    t = contacts[0]
    t.sliding = sliding
    return t


def _force(robot, contacts, rng):
    c = contacts[0]
    d = robot.contacts[c.contact].force_dim
    directions = [[1.0, 0.0, 1.0] + [0.0] * (d - 3), [0.0, 1.0, 0.0] + [0.0] * (d - 3)]
    return Force(c.name, target=[20.0, -3.0], directions=directions)


def _wrench(robot, contacts, rng):
    c = contacts[0]
    return ContactWrench(c.name, target=rng.standard_normal(robot.contacts[c.contact].force_dim))


def _null_space(robot, contacts, rng):
    return NullSpaceImpedance(frame=HAND[robot.name], k_q=0.0, B_nu=3.0)


#: every task type's entry (the function ids in the test names)
CASES: dict[str, tuple[type, Case]] = {
    "frame": (Frame, Case(_frame, "motion")),
    "frame_position": (Frame, Case(lambda r, c, g: _frame(r, c, g, mask="position"), "motion")),
    "frame_orientation_xy": (Frame, Case(lambda r, c, g: _frame(r, c, g, mask=[0, 0, 0, 1, 1, 0]), "motion")),
    "com": (CoM, Case(_com, "motion")),
    "com_xy": (CoM, Case(lambda r, c, g: _com(r, c, g, axes="xy"), "motion")),
    "com_xy_per_axis_gains": (CoM, Case(lambda r, c, g: _com(r, c, g, axes="xy", per_axis=True), "motion")),
    "posture": (Posture, Case(_posture, "motion")),
    "posture_subset": (Posture, Case(lambda r, c, g: _posture(
        r, c, g, joints=lambda robot: list(robot.model.names)[-3:]), "motion")),
    "contact": (Contact, Case(_contact, "motion")),
    "contact_sliding": (Contact, Case(lambda r, c, g: _contact(r, c, g, sliding=True), "motion")),
    "null_space_impedance": (NullSpaceImpedance, Case(_null_space, "null_space")),
    "differential_drive": (DifferentialDrive, Case(lambda r, c, g: DifferentialDrive(), "lateral_velocity",
                                                   robots=("tiago",))),
    "force": (Force, Case(_force, "force")),
    "contact_wrench": (ContactWrench, Case(_wrench, "force")),
    "contact_regularization": (ContactRegularization, Case(lambda r, c, g: ContactRegularization(), "force")),
    "dynamics": (FloatingBaseDynamics, Case(lambda r, c, g: FloatingBaseDynamics(), "dynamics",
                                            robots=("talos", "g1"))),
    "torque_limits": (TorqueLimits, Case(lambda r, c, g: TorqueLimits(scale=0.8), "dynamics")),
    "joint_limits": (JointLimits, Case(lambda r, c, g: JointLimits(), "box")),
    # threshold far above any w: the row is active (w < w_min) at every random state
    "singularity_avoidance": (SingularityAvoidance, Case(
        lambda r, c, g: SingularityAvoidance(HAND[r.name], threshold=1e3, kp=0.0, kd=0.0), "motion")),
    "singularity_avoidance_pose": (SingularityAvoidance, Case(
        lambda r, c, g: SingularityAvoidance(HAND[r.name], threshold=1e3, mask="pose", kp=0.0, kd=0.0), "motion")),
    "singularity_avoidance_com": (SingularityAvoidance, Case(
        lambda r, c, g: SingularityAvoidance("com", threshold=1e3, kp=0.0, kd=0.0), "motion")),
    "collision_avoidance": (CollisionAvoidance, Case(lambda r, c, g: CollisionAvoidance(influence=0.08, safety=0.01),
                                                     "collision", robots=("talos", "tiago"))),
}


def task_classes() -> set[type]:
    """Every Task subclass defined in a module of :mod:`wbc.tasks`."""
    found = set()
    for info in pkgutil.walk_packages(wbc.tasks.__path__, "wbc.tasks."):
        mod = importlib.import_module(info.name)
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if issubclass(cls, Task) and cls.__module__.startswith("wbc.tasks"):
                found.add(cls)
    return found


def test_every_task_type_is_in_the_table():
    covered = {cls for cls, _ in CASES.values()}
    missing = task_classes() - covered - set(EXEMPT)
    assert not missing, f"task types without a finite-difference case in CASES (or a reason in EXEMPT): {missing}"
    assert set(wbc.tasks.TASK_TYPES.values()) <= covered


# ----------------------------------------------------------------- numerical derivatives
def along(robot, q, v, direction, eps, fun):
    """(fun at q ⊕ ε d − fun at q ⊖ ε d) / 2ε, the robot updated at each (with velocity v)."""
    robot.update(pin.integrate(robot.model, q, eps * direction), v)
    plus = np.array(fun(), dtype=float, copy=True)
    robot.update(pin.integrate(robot.model, q, -eps * direction), v)
    minus = np.array(fun(), dtype=float, copy=True)
    robot.update(q, v)
    return (plus - minus) / (2.0 * eps)


def jacobian_fd(robot, q, v, fun) -> np.ndarray:
    """∂fun/∂q along pin.integrate, one column per velocity coordinate."""
    return np.column_stack([along(robot, q, v, np.eye(robot.nv)[i], EPS, fun) for i in range(robot.nv)])


def close(got, want, tol=TOL, what=""):
    scale = max(1.0, float(np.abs(want).max(initial=0.0)))
    err = float(np.abs(got - want).max(initial=0.0))
    assert err <= tol * scale, f"{what}: largest difference {err:.3g} (tolerance {tol * scale:.3g})"
    return err / scale


def setup(robots, name, key, seed):
    robot = robots[name]
    cls, case = CASES[key]
    if name not in case.robots:
        pytest.skip(f"{cls.__name__} does not apply to {name}")
    rng = np.random.default_rng(seed)
    q, v = random_state(robot, rng, speed=SPEED)
    robot.update(q, v)
    contacts = contacts_of(robot)
    task = case.make(robot, contacts, rng)
    levels = [contacts] if task in contacts else [contacts, [task]] if contacts else [[task]]
    stack = wbc.Stack(levels)
    layout = stack.layout(robot)
    task.bind(robot)
    return robot, task, layout, q, v, case.check


def rows_copy(task, robot, layout):
    r = task.rows(robot, layout)
    return r.A.copy(), r.b.copy()


# ----------------------------------------------------------------- the checks
def check_motion(robot, task, layout, q, v):
    nv = robot.nv
    A, b = rows_copy(task, robot, layout)
    assert not np.any(A[:, nv:]), "a motion task's rows have no force columns"
    # the Jacobian block: −∂e/∂q (e = x_d − x)
    J = -jacobian_fd(robot, q, v, lambda: (task.rows(robot, layout), task.error(robot))[1])
    close(A[:, :nv], J, what="A (q̈ block) vs −∂e/∂q")
    # the drift: b = −J̇q̇ with zero gains and references, J̇q̇ = d/dt (A(q) q̇) along q ⊕ t q̇
    Jdot_v = along(robot, q, v, v, EPS, lambda: task.rows(robot, layout).A[:, :nv] @ v)
    close(b, -Jdot_v, what="b vs −J̇q̇")
    # the PD part (5.16, zero references): K_p e − K_d A q̇
    kp, kd = (4.0, 3.0) if np.ndim(task.kp) == 0 else (np.full(len(task.kp), 4.0), np.full(len(task.kp), 3.0))
    task.set_gains(kp, kd)
    robot.update(q, v)
    _, b_pd = rows_copy(task, robot, layout)
    close(b_pd, b + 4.0 * task.error(robot) - 3.0 * (A[:, :nv] @ v), what="b with gains")


def check_null_space(robot, task, layout, q, v):
    """Rows Lᵀ Z# q̈ = L⁻¹ ((μ_ν + B_ν) ν̃ + Zᵀ k_q q̃) − Lᵀ Ż# q̇ (module docstring of the task)."""
    nv = robot.nv
    # Z₀ taken at a state 0.05 rad away: at its own state Z₀ ⊂ ker J, where half of (N1) vanishes
    robot.update(pin.integrate(robot.model, q, 0.05 * np.random.default_rng(5).standard_normal(nv)), v)
    task.rows(robot, layout)
    robot.update(q, v)
    task.target = q.copy()                       # q̃ = 0 here: ∂(Z# q̃)/∂q = −Z#
    A, b = rows_copy(task, robot, layout)
    T = task.last
    L = np.linalg.cholesky(T.Lambda_nu)
    # error = Z# q̃: −∂/∂q at q̃ = 0 is Z#, the rows' A is Lᵀ Z#
    Zs = -jacobian_fd(robot, q, v, lambda: (task.rows(robot, layout), task.error(robot))[1])
    close(A[:, :nv], L.T @ Zs, TOL_NULL_SPACE, "A vs Lᵀ Z# (Z# = −∂(Z# q̃)/∂q)")
    Zs_dot_v = along(robot, q, v, v, EPS, lambda: (task.rows(robot, layout), task.last.Zsharp @ v)[1])
    close(T.Zsharp_dot_v, Zs_dot_v, TOL_NULL_SPACE, "Ż# q̇ vs d/dt (Z# q̇)")
    drive = (T.mu_nu + 3.0 * np.eye(len(b))) @ -(T.Zsharp @ v)   # k_q = 0, no external torque
    close(b, np.linalg.solve(L, drive) - L.T @ Zs_dot_v, TOL_NULL_SPACE, "b vs the drift")


def check_lateral_velocity(robot, task, layout, q, v):
    """Rows e_yᵀ q̈ = −v_y / τ_c: v_y the base's lateral velocity in its own frame (pinocchio's
    root joint velocity, LOCAL), its rate at q̈ = 0 zero (d/dt v_y numerically)."""
    nv = robot.nv
    A, b = rows_copy(task, robot, layout)

    def lateral(vel=v):
        data = robot.model.createData()
        pin.forwardKinematics(robot.model, data, robot.q, vel)
        return np.array([data.v[1].linear[1]])

    J = np.column_stack([(lateral(v + EPS * e) - lateral(v - EPS * e)) / (2 * EPS) for e in np.eye(nv)])
    close(A[:, :nv], J, what="A vs ∂v_y/∂q̇")
    drift = along(robot, q, v, v, EPS, lateral)
    close(b, -lateral() / task.time_constant - drift, what="b vs −v_y/τ_c − d/dt v_y")


def force_error(task, f, layout):
    """(sign, e(f)) of a force task: rows A x = b are ``e(f) = 0`` with A = sign · ∂e/∂x."""
    if isinstance(task, ContactRegularization):                   # W f, W as its docstring says
        w = []
        for name in layout.contact_slices:
            s = layout.surfaces[name]
            X, Y = s.half_length, s.half_width
            w += [1.0, 1.0, task.normal_weight] + ([1.0 / Y, 1.0 / X, 1.0 / np.hypot(X, Y)] if s.kind == "surface" else [])
        return 1.0, np.array(w) * f
    if isinstance(task, ContactWrench):
        return -1.0, task.error_from(f, layout)                   # target − f_c
    sl = layout.contact_slices[task.contact]
    task.feed(f[sl.start - layout.nv: sl.stop - layout.nv], 1e-3)
    return -1.0, task.error(None)                                 # λ_D − S_fᵀ f_m


def check_force(robot, task, layout, q, v):
    nv, nx = layout.nv, layout.nx
    A, b = rows_copy(task, robot, layout)
    assert not np.any(A[:, :nv]), "a force task's rows have no q̈ columns"
    sign, e0 = force_error(task, np.zeros(layout.nf), layout)
    E = np.column_stack([(force_error(task, EPS * e[nv:], layout)[1] - force_error(task, -EPS * e[nv:], layout)[1])
                         / (2 * EPS) for e in np.eye(nx)])
    close(A, sign * E, what="A vs ∂e/∂x")
    close(b, -sign * e0, what="b vs e(0)")
    q2, v2 = random_state(robot, np.random.default_rng(99), speed=SPEED)
    robot.update(q2, v2)
    close(rows_copy(task, robot, layout)[1], b, 0.0, "b does not depend on the state")


def rnea_residual(robot, layout, x) -> np.ndarray:
    """τ = M q̈ + h − J_fᵀ f by pinocchio's RNEA and the contact Jacobians taken afresh."""
    nv, m = robot.nv, robot.model
    data = m.createData()
    tau = pin.rnea(m, data, robot.q, robot.v, x[:nv])
    if robot.compensation is not None:
        tau = tau + robot.compensation.torque(robot.v)
    pin.computeJointJacobians(m, data, robot.q)
    pin.updateFramePlacements(m, data)
    for name, sl in layout.contact_slices.items():
        s = layout.surfaces[name]
        fid = m.getFrameId(s.frame)
        if s.kind == "surface":
            Jc = pin.getFrameJacobian(m, data, fid, pin.ReferenceFrame.LOCAL)
        else:
            Jc = pin.getFrameJacobian(m, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]
        tau = tau - Jc.T @ x[sl]
    return tau


def check_dynamics(robot, task, layout, q, v):
    nx = layout.nx
    rows = task.rows(robot, layout)
    tau0 = rnea_residual(robot, layout, np.zeros(nx))
    D = np.column_stack([(rnea_residual(robot, layout, EPS * e) - rnea_residual(robot, layout, -EPS * e)) / (2 * EPS)
                         for e in np.eye(nx)])
    if isinstance(task, FloatingBaseDynamics):        # S_u τ = 0
        u = robot.unactuated_idx
        close(rows.A, D[u], what="A vs ∂τ_u/∂x")
        close(rows.b, -tau0[u], what="b vs −τ_u(0)")
    else:                                              # −s τ_max ≤ S_a τ ≤ s τ_max
        a = robot.actuated_idx[np.isfinite(robot.tau_max[robot.actuated_idx])]
        close(rows.C, D[a], what="C vs ∂τ_a/∂x")
        close(rows.lo + tau0[a], -task.scale * robot.tau_max[a], what="lo vs −τ_max − τ_a(0)")
        close(rows.hi + tau0[a], task.scale * robot.tau_max[a], what="hi vs τ_max − τ_a(0)")


def check_box(robot, task, layout, q, v):
    """Each bound is on q̈ of one 1-DoF joint: its row is ∂q_j/∂δ along pin.integrate."""
    idx, lo, hi = task.rows(robot, layout).box
    m = robot.model
    q_of_v = {m.joints[j].idx_v: m.joints[j].idx_q for j in range(1, m.njoints) if m.joints[j].nq == 1}
    limited = [i for i in idx if i in q_of_v]
    assert len(limited) >= 5 and np.all(lo <= hi)
    D = jacobian_fd(robot, q, v, lambda: robot.q[[q_of_v[i] for i in limited]])
    close(D, np.eye(robot.nv)[limited], what="box rows vs ∂q_j/∂δ")


def check_collision(robot, task, layout, q, v):
    """Each used row is J_d of its pair (∂d/∂δ along pin.integrate, coal's distance, GJK at
    1e-10 m) and its bound the damper's −2ω ḋ − ω²(d − d_s) − J̇_d q̇; the unused rows are 0."""
    for req in task.model.geometry_data.distanceRequests:
        req.gjk_tolerance = 1e-10
    rows = task.rows(robot, layout)
    r, order = task.last
    k = len(order)
    assert k >= 1, "no pair within the influence distance"
    pairs = r.pairs[order].copy()
    C = rows.C[:k, :robot.nv].copy()
    fd = jacobian_fd(robot, q, v, lambda: task.model.all_distances(robot.q)[pairs])
    close(C, fd, tol=1e-4, what="collision rows vs ∂d/∂δ")
    close(rows.C[:k, robot.nv:], np.zeros((k, layout.nx - robot.nv)), what="no force columns")
    close(rows.C[k:], np.zeros_like(rows.C[k:]), what="unused rows")
    w = task.omega
    close(rows.lo[:k], -2 * w * (C @ v) - w * w * (r.d[order] - task.safety) - r.drift[order], what="damper bound")


CHECKS = {"collision": check_collision,
          "motion": check_motion, "null_space": check_null_space, "lateral_velocity": check_lateral_velocity,
          "force": check_force, "dynamics": check_dynamics, "box": check_box}


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("name", ["talos", "g1", "tiago"])
@pytest.mark.parametrize("key", list(CASES))
def test_rows_match_finite_differences(robots, key, name, seed):
    robot, task, layout, q, v, check = setup(robots, name, key, seed)
    CHECKS[check](robot, task, layout, q, v)


# ----------------------------------------------------------------- the frame's orientation error
#: ‖Jlog₃(θ) − I‖₂: the largest relative error of −J_ω q̇ as the rate of log₃(R_d Rᵀ) at an
#: error of θ rad (Frame's docstring): |(θ/2) cot(θ/2) − 1 + i θ/2|
def jlog3_defect(theta: float) -> float:
    return abs(complex(0.5 * theta / np.tan(0.5 * theta) - 1.0, 0.5 * theta))


@pytest.mark.parametrize("theta", [0.1, 0.5, 1.0])
def test_frame_orientation_error_approximation(robots, theta):
    """At an orientation error of θ rad, −∂log₃(R_d Rᵀ)/∂q = Jlog₃(R_d Rᵀ) J_ω exactly, and the
    rows' J_ω is off by at most ‖Jlog₃ − I‖ (5 %, 25 %, 51 % at 0.1, 0.5, 1 rad), reached for
    an angular velocity across the error axis: the numbers in Frame's docstring."""
    robot = robots["talos"]
    rng = np.random.default_rng(7)
    q, v = random_state(robot, rng, speed=SPEED)
    robot.update(q, v)
    task = Frame("left_hand", kp=0.0, kd=0.0, mask="orientation")
    M = robot.frame_placement(robot.frame_id("left_hand"))
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    task.target = pin.SE3(pin.exp3(theta * axis) @ M.rotation, M.translation)
    layout = wbc.Stack([[task]]).layout(robot)
    A, _ = rows_copy(task, robot, layout)
    E = pin.log3((task.target * M.inverse()).rotation)
    assert np.linalg.norm(E) == pytest.approx(theta)
    D = -jacobian_fd(robot, q, v, lambda: task.error(robot))
    close(D, pin.Jlog3(pin.exp3(E)) @ A[:, : robot.nv], what="−∂e/∂q vs Jlog₃ J_ω")
    # worst relative error of the rows over the joint directions
    cols = np.linalg.norm(A[:, : robot.nv], axis=0) > 1e-3
    rel = np.linalg.norm(D[:, cols] - A[:, : robot.nv][:, cols], axis=0) / np.linalg.norm(A[:, : robot.nv][:, cols],
                                                                                           axis=0)
    bound = jlog3_defect(theta)
    assert rel.max() <= bound * (1 + 1e-4)
    assert rel.max() >= 0.8 * bound
    assert bound == pytest.approx({0.1: 0.050, 0.5: 0.251, 1.0: 0.507}[theta], abs=1e-3)


# ----------------------------------------------------------------- the velocity forms (wbc.tasks.velocity)
VELOCITY_DT = 0.01


def _velocity_check(robot, task, q, v):
    """The task's velocity rows (x = q̇) against finite differences of what they drive: a motion
    task's A = −∂e/∂q and b = K e (K = 2/s given, zero reference velocity); the collision rows'
    C = ∂d/∂q and the damper bound −ξ (d − d_s)/(d_i − d_s); the joint-limit box from the limits
    and q directly; the differential drive's row picks v_y."""
    from wbc.tasks.velocity import velocity_rows

    nv = robot.nv
    if task.kind == "collision_avoidance":
        for req in task.model.geometry_data.distanceRequests:
            req.gjk_tolerance = 1e-10
    rows = velocity_rows(task, robot, nv, VELOCITY_DT, gain=2.0)
    if task.kind in ("frame", "com", "posture", "contact"):
        A, b = rows.A.copy(), rows.b.copy()
        J = -jacobian_fd(robot, q, v, lambda: task.error(robot))
        close(A, J, what="velocity A vs −∂e/∂q")
        close(b, 2.0 * task.error(robot), what="velocity b vs K e")
    elif task.kind == "collision_avoidance":
        r, order = task.last
        k = len(order)
        assert k >= 1, "no pair within the influence distance"
        pairs = r.pairs[order].copy()
        C = rows.C[:k].copy()
        d = task.model.all_distances(robot.q)[pairs]
        fd = jacobian_fd(robot, q, v, lambda: task.model.all_distances(robot.q)[pairs])
        close(C, fd, tol=1e-4, what="velocity collision rows vs ∂d/∂δ")
        close(rows.lo[:k], -task.max_speed * (d - task.safety) / (task.influence - task.safety), tol=1e-8,
              what="velocity damper bound")
        close(rows.C[k:], np.zeros_like(rows.C[k:]), what="unused rows")
    elif task.kind == "joint_limits":
        idx, lo, hi = rows.box
        D = jacobian_fd(robot, q, v, lambda: robot.q[7:] if robot.root == "free_flyer" else robot.q)
        assert len(idx) >= 5 and np.all(lo <= hi)
        k = min(1.0 / task.horizon, 1.0 / VELOCITY_DT)
        for i, lo_i, hi_i in zip(idx, lo, hi):
            (col,) = np.flatnonzero(np.abs(D[:, i]) > 0.5)          # the q coordinate of velocity i
            qq = robot.q[col + (7 if robot.root == "free_flyer" else 0)]
            qi = col + (7 if robot.root == "free_flyer" else 0)
            want_hi = min(robot.v_max[i], k * (robot.q_max[qi] - task.margin - qq))
            want_lo = max(-robot.v_max[i], k * (robot.q_min[qi] + task.margin - qq))
            if want_lo <= want_hi:
                assert (lo_i, hi_i) == pytest.approx((want_lo, want_hi), abs=1e-12)
    elif task.kind == "differential_drive":
        close(rows.A, np.eye(nv)[1:2], what="lateral velocity row")
        close(rows.b, np.zeros(1), what="no lateral velocity")
    else:
        raise AssertionError(task.kind)


@pytest.mark.parametrize("seed", SEEDS[:2])
@pytest.mark.parametrize("name", ["talos", "tiago"])
@pytest.mark.parametrize("key", list(CASES))
def test_velocity_rows_match_finite_differences(robots, key, name, seed):
    """Every task kind with a velocity form (:data:`wbc.tasks.velocity.VELOCITY_KINDS`) is checked;
    the others are refused by name (TaskDefinitionError naming ``stack[0][0].type``)."""
    from wbc.errors import TaskDefinitionError
    from wbc.tasks.velocity import VELOCITY_KINDS, check_velocity_stack

    robot, task, layout, q, v, _ = setup(robots, name, key, seed)
    if task.kind not in VELOCITY_KINDS:
        with pytest.raises(TaskDefinitionError, match=r"stack\[0\]\[0\]\.type"):
            check_velocity_stack([[task]])
        return
    robot.update_kinematics(q, v)
    _velocity_check(robot, task, q, v)
