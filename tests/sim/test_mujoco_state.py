"""MuJoCo's state read in pinocchio's coordinates after every step (issue #26): q from qpos in one
compiled call (:mod:`wbc.sim.mujoco_state`) and v = T(q)ᵀ qvel with T held between calls (its
root block rewritten at each), both bit for bit the former code's, for a free-flyer root
(Talos) and a planar one with continuous wheels (TIAGo)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

from wbc.scenario.loader import load_config  # noqa: E402
from wbc.sim.backends import make_simulator  # noqa: E402


def _former_q(sim, qpos: np.ndarray) -> np.ndarray:
    q, a = np.zeros(sim.model.nq), sim._root_q
    if sim.root == "free_flyer":
        q[:3] = qpos[a: a + 3]
        quat = qpos[a + 3: a + 7]
        w, x, y, z = quat / math.sqrt(quat.dot(quat))
        q[3:7] = x, y, z, w
    elif sim.root == "planar":
        q[:4] = qpos[a], qpos[a + 1], math.cos(qpos[a + 2]), math.sin(qpos[a + 2])
    q[sim._qi] = qpos[sim._qm]
    for iq, im in sim._cont:
        q[iq], q[iq + 1] = math.cos(qpos[im]), math.sin(qpos[im])
    return q


@pytest.mark.parametrize("name, scenario", [("talos", "talos_balance"), ("tiago", "tiago_table_reach")])
def test_state_read_bit_for_bit(name, scenario):
    import wbc

    robot = wbc.load_robot(name)
    sc = load_config(scenario)
    sim = make_simulator("mujoco", robot, sc.environment, dt=1e-3, tau_limits=robot.tau_max)
    rng = np.random.default_rng(1)
    nq, nv = sim.mj_model.nq, sim.mj_model.nv
    for k in range(300):
        qpos = rng.normal(size=nq)
        if sim.root == "free_flyer":
            qpos[sim._root_q + 3: sim._root_q + 7] *= rng.uniform(0.5, 2.0)     # a quaternion not of unit norm
        q = sim.q_from_qpos(qpos)
        want = _former_q(sim, qpos)
        assert np.array_equal(q, want), (k, q - want)
        qvel = rng.normal(size=nv)
        assert np.array_equal(sim.v_from_qvel(q, qvel), sim.velocity_map(q).T @ qvel), k


def _sim(name: str, scenario: str):
    import wbc

    robot = wbc.load_robot(name)
    return make_simulator("mujoco", robot, load_config(scenario).environment, dt=1e-3, tau_limits=robot.tau_max)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.tobytes() == b.tobytes()       # bit for bit, signed zeros and NaN patterns included


@pytest.mark.parametrize("name, scenario", [("talos", "talos_balance"), ("panda", "panda_obstacle")])
def test_compiled_state_read_is_the_general_path_bit_for_bit(name, scenario):
    """The step's read-out (mujoco_state.read_state: the quaternion's norm, Eigen's rotation and
    OpenBLAS's T.T @ qvel written out) against q_from_qpos / v_from_qvel on random states: unit
    and non-unit quaternions, seven decades of velocities, signed zeros."""
    sim = _sim(name, scenario)
    assert sim._reader is not None, "the compiled read-out is in use on this host"
    rng = np.random.default_rng(7)
    nq, nv = sim.mj_model.nq, sim.mj_model.nv
    for k in range(3000):
        qpos = rng.normal(size=nq) * 10.0 ** rng.integers(-3, 3)
        qvel = rng.normal(size=nv) * 10.0 ** rng.integers(-5, 4, size=nv)
        if sim.root == "free_flyer":
            quat = qpos[sim._root_q + 3: sim._root_q + 7]
            quat *= 1.0 / np.linalg.norm(quat) if k % 3 == 0 else rng.uniform(0.5, 2.0)
        if k % 5 == 0:
            qvel[rng.integers(nv, size=3)] = -0.0
        q, v = sim._reader.read(qpos, qvel)
        q_ref = sim.q_from_qpos(qpos)
        assert _same(q, q_ref), (k, q - q_ref)
        assert _same(v, sim.velocity_map(q_ref).T @ qvel), k


def test_planar_root_keeps_the_general_path():
    assert _sim("tiago", "tiago_table_reach")._reader is None


@pytest.mark.filterwarnings("ignore:invalid value encountered in matmul:RuntimeWarning")
def test_non_finite_velocity_takes_the_general_path():
    """A NaN or inf in qvel: the product T.T @ qvel is NaN in every entry, the read-out too."""
    sim = _sim("talos", "talos_balance")
    qpos, qvel = sim.mj_data.qpos.copy(), np.zeros(sim.mj_model.nv)
    qvel[9] = np.inf
    assert sim._reader.read(qpos, qvel) is None
    sim.mj_data.qvel[:] = qvel
    sim._read_state()
    want = sim.velocity_map(sim.q).T @ qvel
    assert not np.isfinite(want).any() and _same(sim.v, want)


def test_steps_with_contacts_read_the_general_path_state_and_command():
    """Talos standing on the ground (feet in contact), 200 steps of gravity-ish torques, some past
    the limits, a push: after each, sim.q / sim.v are the general path's at MuJoCo's state, ctrl
    is τ's actuated entries, the saturated steps those with |τ| > τ_max, xfrc_applied zero
    outside the push."""
    import pinocchio as pin

    sim = _sim("talos", "talos_balance")
    d = sim.mj_data
    act = np.asarray(sim.robot.actuated_idx)
    lim = sim.tau_limits[act]
    tau0 = pin.rnea(sim.model, sim.model.createData(), sim.q, sim.v, np.zeros(sim.model.nv))
    rng = np.random.default_rng(3)
    sim.push("torso_2_link", [30.0, 0.0, 0.0], 0.05, 0.02)
    saturated = 0
    for k in range(200):
        tau = tau0 * rng.uniform(0.8, 1.2, size=tau0.shape)
        if k % 17 == 0:
            tau[act[k % len(act)]] = 2.0 * lim[k % len(act)]
        if k % 2:
            tau = tau[act]          # the actuated entries only
        full = tau.shape[0] == sim.model.nv
        saturated += bool(np.any(np.abs(tau[act] if full else tau) > lim))
        sim.step(tau)
        assert _same(d.ctrl, tau[act] if full else tau), k
        assert sim.saturated_steps == saturated, k
        if not 0.05 <= sim.t - 1e-3 < 0.07:
            assert not d.xfrc_applied.any(), k
        q, v = sim._general_state(d.qpos, d.qvel)
        assert _same(sim.q, q) and _same(sim.v, v), k
    assert d.ncon > 0 and saturated > 0
    bad = tau0.copy()
    bad[act[0]] = np.nan
    with pytest.raises(Exception, match="non-finite"):
        sim.step(bad)


def test_frame_velocity_after_point_positions_uses_fresh_com_quantities():
    """point_positions runs mj_kinematics only; frame_velocity (mj_jac: subtree CoMs, cdof) then
    runs mj_comPos: the velocity equals the one of a full mj_forward at the same state."""
    import mujoco

    sim = _sim("talos", "talos_balance")
    sim.step(np.zeros(sim.model.nv))
    sim.step(np.zeros(sim.model.nv))
    sim.point_positions()
    got = sim.frame_velocity("left_sole_link")
    mujoco.mj_forward(sim.mj_model, sim.mj_data)
    assert np.array_equal(got, sim.frame_velocity("left_sole_link"))


def test_step_without_pushes_clears_a_wrench_written_from_outside():
    """No pushes: every step starts with xfrc_applied zeroed (now in the compiled command), so
    a wrench written into MuJoCo's data beforehand acts on no step."""
    a, b = _sim("talos", "talos_balance"), _sim("talos", "talos_balance")
    a.mj_data.xfrc_applied[3] = 50.0
    for _ in range(3):
        a.step(np.zeros(a.model.nv))
        b.step(np.zeros(b.model.nv))
        assert not a.mj_data.xfrc_applied.any()
    assert _same(a.q, b.q) and _same(a.v, b.v)
