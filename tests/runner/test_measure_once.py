"""The simulator is measured exactly once per control cycle, events included.

``measure()`` has side effects: it pushes into the latency queue and draws the sensor noise.
A timeline event (``add``, ``touchdown``) that measured again would shift the delay and consume
random draws, so the controller would see a different sensor stream than the simulator produced.
"""

from __future__ import annotations

import numpy as np
import yaml

from wbc.runner.loop import ScenarioRun
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config


class RecordingSimulator:
    """The simulator, with every ``measure()`` output kept (copies)."""

    def __init__(self, sim):
        self._sim, self.measurements = sim, []

    def measure(self):
        q, v = self._sim.measure()
        self.measurements.append((q.copy(), v.copy()))
        return q, v

    def __getattr__(self, name):
        return getattr(self._sim, name)


def test_events_do_not_measure_again_with_latency_and_noise(tmp_path):
    doc = yaml.safe_load((SCENARIOS_DIR / "talos_step.yaml").read_text())
    doc["sensing"] = {"noise_q": 1e-4, "noise_v": 1e-3, "latency_steps": 2}
    doc["duration"] = 0.02
    for ev in doc["events"]:            # add, release, touchdown, remove: inside the short run, in order
        ev["time"] = round(ev["time"] * 0.004, 4)
        if "duration" in ev:
            ev["duration"] = 0.002
    path = tmp_path / "step_events.yaml"
    path.write_text(yaml.safe_dump(doc))
    sims: list[RecordingSimulator] = []
    run = ScenarioRun(load_config(path), duration=0.02,
                      wrap_simulator=lambda sim: sims.append(RecordingSimulator(sim)) or sims[-1])
    seen = []
    solve = run.ctrl.solve

    def solve_and_keep(q, v, tau_e=None):
        seen.append((q.copy(), v.copy()))
        return solve(q, v, tau_e)

    run.ctrl.solve = solve_and_keep
    for k in range(run.n):
        assert run.cycle(k)
    assert len(run.pending) == 0, "every event ran"
    produced = sims[0].measurements
    assert len(produced) == len(seen) == run.n
    for (qs, vs), (qc, vc) in zip(produced, seen):
        np.testing.assert_array_equal(qs, qc)
        np.testing.assert_array_equal(vs, vc)
