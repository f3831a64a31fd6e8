"""benchmarks/same_replay.py, the per-cycle check of a change that moves the last bits: a replay
gives the controller the recorded states whatever the live plant does, and ``compare`` fails a
change above its tolerance and passes one below it. Nothing here asserts a wall-clock time."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks import same_replay
from wbc.controller.cycle import Controller
from wbc.sim.simulator import Simulator

CASE = [("talos_balance", "hqp", 0.05)]
KEY = "talos_balance/pinocchio/hqp/out"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "run.npz"
    same_replay.record(str(path), CASE, ["pinocchio"])
    return path


def test_replay_gives_the_controller_the_recorded_states_not_the_live_plants(recorded, tmp_path, monkeypatch):
    step = Simulator.step
    # the live plant leaves the recording at once: 0.5 N·m more on every joint, every cycle
    monkeypatch.setattr(Simulator, "step", lambda self, tau: step(self, tau + 0.5))
    out = tmp_path / "new.npz"
    same_replay.replay(str(recorded), str(out))
    a, b = np.load(recorded), np.load(out)
    assert a[KEY].shape == (50, 32)
    assert np.array_equal(a[KEY], b[KEY])
    assert same_replay.compare(str(recorded), str(out)) == 0


@pytest.mark.parametrize("scale, verdict", [(1e-6, 1), (1e-12, 0)])
def test_compare_fails_a_controller_change_above_the_tolerance_only(recorded, tmp_path, monkeypatch, scale, verdict):
    solve = Controller.solve

    def moved(self, *args, **kwargs):
        sol = solve(self, *args, **kwargs)
        sol.tau = sol.tau * (1.0 + scale)
        return sol

    monkeypatch.setattr(Controller, "solve", moved)
    out = tmp_path / "new.npz"
    same_replay.replay(str(recorded), str(out))
    assert not np.array_equal(np.load(recorded)[KEY], np.load(out)[KEY])
    assert same_replay.compare(str(recorded), str(out)) == verdict


def test_replay_drives_the_plant_with_the_recorded_torques(recorded, monkeypatch):
    data = np.load(recorded)
    key = KEY.rsplit("/", 1)[0]
    given = {f: data[f"{key}/{f}"] for f in ("q", "v", "tau_e", "has_tau_e", "sent")}
    solve, measure = Controller.solve, Simulator.measure
    live: list = []

    def pushed(self, *args, **kwargs):      # a controller whose torques alone would move the plant elsewhere
        sol = solve(self, *args, **kwargs)
        sol.tau_full = sol.tau_full * 1.5
        return sol

    def measured(self):
        q, v = measure(self)
        live.append(q.copy())
        return q, v

    monkeypatch.setattr(Controller, "solve", pushed)
    monkeypatch.setattr(Simulator, "measure", measured)
    same_replay.run_case("talos_balance", "hqp", 0.05, "pinocchio", given)
    assert len(live) == 50
    assert np.array_equal(np.array(live), given["q"])     # the live plant is the recording's, bit for bit
