"""The MuJoCo back-end (wbc.sim.mujoco_sim) against pinocchio, on Talos, TIAGo and the Panda.

Model checks at random states (5 per robot): the compiled bodies' masses, CoMs and
inertias equal pinocchio's joint inertias to 1e-10 relative (also when MuJoCo reads the
URDF inertials itself, Talos and Panda); q <-> qpos round trips; the velocity convention
qvel = T(q) v by central finite differences of the configurations (1e-8, the O(ε²) error);
M(q) = Tᵀ M_mj T and h = Tᵀ(M_mj Ṫ v + h_mj) to 1e-10 relative; a distal frame's placement and
velocity to 1e-12; forward dynamics with motor torques (no contact) to 1e-9 relative; the
actuators' generalized forces (TIAGo's base site motors included) to 1e-12.
Pushes: the wrench MuJoCo applies at the body's CoM has pinocchio's net force and moment
about any point (1e-12), the same generalized force (1e-10) and, through a step, the same
acceleration (1e-9 relative). Simulation: Talos standing on the ground under pinocchio's
gravity-compensation torques for 0.5 s (tolerances at the test); TIAGo's differential
drive keeps zero lateral base velocity (1e-12 m/s) while pushed sideways.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

mujoco = pytest.importorskip("mujoco", reason="the MuJoCo back-end needs mujoco (pip install mujoco==4.0.0)")

import wbc  # noqa: E402
from wbc.sim import ground  # noqa: E402
from wbc.sim.mujoco_sim import MujocoSimulator  # noqa: E402

ROBOTS = ["talos", "tiago", "panda"]
DISTAL = {"talos": "gripper_right_base_link", "tiago": "arm_tool_link", "panda": "panda_hand"}
N_STATES = 5


@pytest.fixture(scope="module")
def robots(talos, tiago):
    return {"talos": talos, "tiago": tiago, "panda": wbc.load_robot("panda")}


@pytest.fixture(scope="module")
def sims(robots):
    return {name: MujocoSimulator.for_robot(r, []) for name, r in robots.items()}


def _random_state(robot, rng):
    q = robot.random_configuration(rng)
    if robot.root == "free_flyer":
        q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
    elif robot.root == "planar":
        th = rng.uniform(-np.pi, np.pi)
        q[2:4] = np.cos(th), np.sin(th)
    return q, rng.normal(size=robot.nv)


def _inertia_matrix(mm, b) -> np.ndarray:
    """A body's rotational inertia about its CoM in the body frame (MuJoCo stores principal axes)."""
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, mm.body_iquat[b])
    R = R.reshape(3, 3)
    return R @ np.diag(mm.body_inertia[b]) @ R.T


# ------------------------------------------------------------------ model
@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("inertias", ["model", "urdf"])
def test_masses_and_inertias(robots, name, inertias):
    robot = robots[name]
    m = robot.model
    if name == "tiago" and inertias == "urdf":
        # TIAGo's URDF has non-positive-definite inertias (the antenna links) that
        # pinocchio accepts and MuJoCo's compiler refuses: hence inertias="model"
        with pytest.raises(ValueError, match="positive eigenvalues"):
            MujocoSimulator.for_robot(robot, [], inertias="urdf")
        return
    sim = MujocoSimulator.for_robot(robot, [], inertias=inertias)
    mm = sim.mj_model
    moving = sum(m.inertias[j].mass for j in range(1, m.njoints))
    assert abs(mm.body_mass[1:].sum() - moving) <= 1e-10 * moving
    assert abs(pin.computeTotalMass(m) - moving) <= 1e-10 * moving
    assert mm.nbody == m.njoints      # one body per pinocchio joint (fixed links fused), + the world
    for j in range(1, m.njoints):
        b, Y = sim._body[j], m.inertias[j]
        assert abs(mm.body_mass[b] - Y.mass) <= 1e-10 * max(Y.mass, 1e-3), m.names[j]
        assert np.abs(mm.body_ipos[b] - Y.lever).max() <= 1e-10 * max(np.abs(Y.lever).max(), 1e-3), m.names[j]
        scale = max(np.abs(Y.inertia).max(), 1e-9)
        assert np.abs(_inertia_matrix(mm, b) - Y.inertia).max() <= 1e-10 * scale, m.names[j]


@pytest.mark.parametrize("name", ROBOTS)
def test_configuration_and_velocity_conventions(robots, sims, name, rng):
    robot, sim = robots[name], sims[name]
    m, mm = robot.model, sim.mj_model
    eps = 1e-5
    for _ in range(N_STATES):
        q, v = _random_state(robot, rng)
        assert np.abs(pin.difference(m, q, sim.q_from_qpos(sim.qpos_from_q(q)))).max() < 1e-14
        # pinocchio's q ⊕ ±ε v, differentiated by MuJoCo on its own coordinates
        qp, qm = (sim.qpos_from_q(pin.integrate(m, q, s * eps * v)) for s in (1.0, -1.0))
        qvel = np.zeros(mm.nv)
        mujoco.mj_differentiatePos(mm, qvel, 2 * eps, qm, qp)
        assert np.abs(qvel - sim.qvel_from_v(q, v)).max() < 1e-8 * max(1.0, np.abs(v).max())
        sim.set_state(q, v)
        assert np.abs(sim.v - v).max() < 1e-14 * max(1.0, np.abs(v).max())


@pytest.mark.parametrize("name", ROBOTS)
def test_mass_matrix_and_bias_forces(robots, sims, name, rng):
    robot, sim = robots[name], sims[name]
    m, d, mm, md = robot.model, robot.model.createData(), sim.mj_model, sim.mj_data
    for _ in range(N_STATES):
        q, v = _random_state(robot, rng)
        sim.set_state(q, v)           # mj_forward: M and the bias forces at (qpos, qvel)
        M_mj = np.zeros((mm.nv, mm.nv))
        mujoco.mj_fullM(mm, md, M_mj)
        T = sim.velocity_map(q)
        M = pin.crba(m, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        assert np.abs(T.T @ M_mj @ T - M).max() <= 1e-10 * np.abs(M).max()
        h = pin.nonLinearEffects(m, d, q, v)
        h_mj = T.T @ (M_mj @ sim.velocity_map_rate(q, v) + md.qfrc_bias)
        assert np.abs(h_mj - h).max() <= 1e-10 * np.abs(h).max()


@pytest.mark.parametrize("name", ROBOTS)
def test_distal_frame_placement_and_velocity(robots, sims, name, rng):
    robot, sim = robots[name], sims[name]
    m, d = robot.model, robot.model.createData()
    fid = m.getFrameId(DISTAL[name])
    for _ in range(N_STATES):
        q, v = _random_state(robot, rng)
        sim.set_state(q, v)
        pin.forwardKinematics(m, d, q, v)
        pin.updateFramePlacements(m, d)
        assert np.abs(sim.frame_placement(DISTAL[name]).homogeneous - d.oMf[fid].homogeneous).max() < 1e-12
        vf = pin.getFrameVelocity(m, d, fid, pin.LOCAL_WORLD_ALIGNED).vector
        assert np.abs(sim.frame_velocity(DISTAL[name]) - vf).max() < 1e-12 * max(1.0, np.abs(vf).max())


@pytest.mark.parametrize("name", ROBOTS)
def test_forward_dynamics_and_actuators(robots, name, rng):
    """One step with motor torques within their limits, no contact: MuJoCo's q̈ = T a + Ṫ v,
    a pinocchio's ABA; the motors' generalized forces are τ in pinocchio's coordinates."""
    robot = robots[name]
    m, d = robot.model, robot.model.createData()
    sim = MujocoSimulator.for_robot(robot, [], joint_limits=False)
    sim.differential_drive = False        # free dynamics (the constraint has its own test)
    for _ in range(N_STATES):
        q, v = _random_state(robot, rng)
        tau = np.zeros(m.nv)
        tau[robot.actuated_idx] = rng.uniform(-0.5, 0.5, robot.na) * robot.tau_max[robot.actuated_idx]
        sim.set_state(q, 0.1 * v)
        sim.step(tau)                 # mj_step: q̈ and the actuator forces at the state before
        T = sim.velocity_map(q)
        assert np.abs(T.T @ sim.mj_data.qfrc_actuator - tau).max() < 1e-12 * np.abs(tau).max()
        a = pin.aba(m, d, q, 0.1 * v, tau)
        qacc = T @ a + sim.velocity_map_rate(q, 0.1 * v)
        assert np.abs(sim.mj_data.qacc - qacc).max() <= 1e-9 * np.abs(qacc).max()


# ------------------------------------------------------------------ pushes
@pytest.mark.parametrize("frame", ["torso_2_link", "gripper_left_base_link", "right_sole_link"])
def test_push_application_point(robots, frame, rng):
    robot = robots["talos"]
    m, d = robot.model, robot.model.createData()
    sim = MujocoSimulator.for_robot(robot, [], joint_limits=False)
    mm, md = sim.mj_model, sim.mj_data
    fid = m.getFrameId(frame)
    F = np.array([150.0, -40.0, 25.0])
    sim.push(frame, F, start=0.0, duration=1.0)
    for _ in range(N_STATES):
        q, v = _random_state(robot, rng)
        v *= 0.1
        sim.set_state(q, v)
        sim.t = 0.0
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        p = d.oMf[fid].translation
        x = sim.push_wrenches(0.5)
        (b,) = np.flatnonzero(np.abs(x).sum(axis=1))
        c = rng.normal(size=3)        # any point: the net wrench about it is pinocchio's
        assert np.abs(x[b, :3] - F).max() < 1e-12
        assert np.abs(np.cross(md.xipos[b] - c, x[b, :3]) + x[b, 3:] - np.cross(p - c, F)).max() < 1e-12 * 150
        jp, jr = np.zeros((3, mm.nv)), np.zeros((3, mm.nv))
        mujoco.mj_jac(mm, md, jp, jr, md.xipos[b], b)
        gen = sim.velocity_map(q).T @ (jp.T @ x[b, :3] + jr.T @ x[b, 3:])
        J = pin.getFrameJacobian(m, d, fid, pin.LOCAL_WORLD_ALIGNED)
        assert np.abs(gen - J[:3].T @ F).max() < 1e-10 * 150
        # through a step of the simulator: the same acceleration as ABA with the external force
        sim.step(np.zeros(m.nv))
        fext = [pin.Force.Zero() for _ in range(m.njoints)]
        j = m.frames[fid].parentJoint
        fext[j] = d.oMi[j].actInv(pin.Force(F, np.cross(p, F)))
        qacc = sim.velocity_map(q) @ pin.aba(m, d, q, v, np.zeros(m.nv), fext) + sim.velocity_map_rate(q, v)
        assert np.abs(md.qacc - qacc).max() <= 1e-9 * np.abs(qacc).max()


# ------------------------------------------------------------------ simulation
def _gravity_compensation(robot, d, q) -> np.ndarray:
    """τ = g(q) − Jᵀ f, f the least-norm sole wrenches (local frames) that carry the base's g."""
    m = robot.model
    g = pin.computeGeneralizedGravity(m, d, q)
    pin.computeJointJacobians(m, d, q)
    pin.updateFramePlacements(m, d)
    J = np.vstack([pin.getFrameJacobian(m, d, m.getFrameId(c.frame), pin.LOCAL) for c in robot.contacts.values()])
    f = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
    return g - J.T @ f


def test_talos_stands_under_gravity_compensation(talos):
    """Talos at its default posture on the ground (μ = 0.8), τ = pinocchio's gravity
    compensation at the measured state, 0.5 s. MuJoCo's soft contact lets the soles sink
    ~0.7 mm in the first 0.1 s (the knees extend ~5 mrad to follow); then nothing moves."""
    m, d = talos.model, talos.model.createData()
    q0 = talos.q_default
    sim = MujocoSimulator.for_robot(talos, [ground(mu=0.8)])
    p0 = sim.point_positions()
    for k in range(500):
        q, _ = sim.measure()
        sim.step(_gravity_compensation(talos, d, q))
        if k == 99:
            q_settled = sim.q.copy()
    q, v = sim.q, sim.v
    dp = sim.point_positions() - p0
    assert np.abs(q[:3] - q0[:3]).max() < 1e-4                                 # base: 0.1 mm
    assert np.linalg.norm(pin.difference(m, q0, q)[3:6]) < np.radians(0.05)   # base tilt: 0.05°
    assert np.abs(pin.difference(m, q0, q)[6:]).max() < 6e-3                   # joints: 6 mrad
    assert np.linalg.norm(dp[:, :2], axis=1).max() < 1e-5                      # sole slip: 0.01 mm
    assert 0.0 < -dp[:, 2].min() < 1e-3                                        # sole sink: < 1 mm
    assert np.abs(pin.difference(m, q_settled, q)).max() < 1e-4                # 0.1-0.5 s: 0.1 mrad
    assert np.abs(v).max() < 1e-3
    assert sim.solver_failures == 0
    # 8 corner contacts, elliptic cones of the environment's μ, the scenario's 1 ms step
    mm, md = sim.mj_model, sim.mj_data
    assert md.ncon == 8 and mm.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and mm.opt.timestep == 1e-3
    assert all(c.dim == 3 and c.mu == 0.8 for c in md.contact[: md.ncon])
    # the feet carry the weight; the sole wrenches and the per-point forces agree
    mg = talos.mass * np.linalg.norm(m.gravity.linear)
    total = np.zeros(3)
    for c in talos.contacts.values():
        w = sim.contact_wrench(c.frame)
        R = sim.frame_placement(c.frame).rotation
        jid = m.frames[m.getFrameId(c.frame)].parentJoint
        pts = [i for i, (j, _) in enumerate(sim.points) if j == jid]
        assert np.abs(R @ w[:3] - sim.point_forces[pts].sum(axis=0)).max() < 1e-3
        assert abs(w[2] - mg / 2) < 0.02 * mg
        total += R @ w[:3]
    assert abs(total[2] - mg) < 1e-3 * mg and np.linalg.norm(total[:2]) < 1e-3 * mg


def test_tiago_differential_drive(tiago):
    """Base force (100 N forward, 300 N sideways) and 10 N·m yaw torque, joints held by PD +
    gravity for 1 s: the base's lateral velocity stays zero, it drives forward and turns."""
    m, d = tiago.model, tiago.model.createData()
    q0 = tiago.q_default
    sim = MujocoSimulator.for_robot(tiago, [])
    lateral = 0.0
    for _ in range(1000):
        q, v = sim.measure()
        tau = pin.computeGeneralizedGravity(m, d, q) + 100.0 * pin.difference(m, q, q0) - 10.0 * v
        tau[:3] = 100.0, 300.0, 10.0
        sim.step(tau)
        lateral = max(lateral, abs(sim.v[1]))
    assert lateral < 1e-12
    assert sim.v[0] > 0.5 and sim.v[2] > 0.3
