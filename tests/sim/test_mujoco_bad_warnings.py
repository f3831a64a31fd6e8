"""MuJoCo's simulator counts a step MuJoCo reset (a bad qpos, qvel or qacc: its warnings) as a
solver failure; the count is read from MuJoCo's live warning counters as three ints (#26), the same
as the sum over the index array it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.scenario.loader import load_config
from wbc.sim.backends import make_simulator


@pytest.mark.parametrize("field", ["qpos", "qvel", "qfrc_applied"])
def test_each_bad_state_counts_one_failure(talos, field):
    """A NaN written into qpos, qvel or the applied forces (MuJoCo's BADQPOS, BADQVEL, BADQACC)
    makes the next step a reset, counted once; the steps before and after count none; the count
    read equals the former sum over the warnings' index array."""
    pytest.importorskip("mujoco")
    from wbc.sim import mujoco_sim as ms

    sc = load_config("talos_balance")
    sim = make_simulator("mujoco", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)
    tau = np.zeros(sim.model.nv)
    sim.step(tau)
    assert sim.solver_failures == 0
    getattr(sim.mj_data, field)[3] = np.nan
    sim.step(tau)
    assert sim.solver_failures == 1, field
    sim.mj_data.qfrc_applied[:] = 0.0
    sim.step(tau)
    assert sim.solver_failures == 1
    assert sim._bad_warnings() == int(sim._warned[ms._BAD].sum()) >= 1
