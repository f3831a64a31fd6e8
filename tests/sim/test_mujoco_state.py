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
