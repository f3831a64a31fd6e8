"""The whole closed loop: controller and physics at 1 kHz, metrics collected, no viewer.

:func:`sim_loop` runs a bundled scenario as ``wbc run <scenario> --headless`` does
(:func:`wbc.runner.loop.run`) and reports, per solver, the real-time factor (simulated time /
wall time, > 1 is faster than real time) and the median per cycle of the controller
(the runner's own ``cycle_time``) and of the simulator step. The step is timed by
:class:`TimedSimulator`, which the runner drives in place of the simulator
(``run(..., wrap_simulator=TimedSimulator)``): nothing of the simulator is patched.
"""

from __future__ import annotations

import time

import numpy as np

from wbc.runner.loop import run as run_scenario
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config
from wbc.sim.backends import PhysicsSimulator


class TimedSimulator:
    """A :class:`~wbc.sim.backends.PhysicsSimulator` that forwards every member to
    ``sim`` and times each :meth:`step` (wall time in s, appended to :attr:`step_times`)."""

    def __init__(self, sim: PhysicsSimulator) -> None:
        self.sim = sim
        self.step_times: list[float] = []

    # what the runner reads of its simulator, as the wrapped one has it now
    model = property(lambda self: self.sim.model)
    data = property(lambda self: self.sim.data)
    t = property(lambda self: self.sim.t)
    q = property(lambda self: self.sim.q)
    v = property(lambda self: self.sim.v)
    points = property(lambda self: self.sim.points)
    point_forces = property(lambda self: self.sim.point_forces)
    pushes = property(lambda self: self.sim.pushes)
    saturated_steps = property(lambda self: self.sim.saturated_steps)

    def step(self, tau: np.ndarray) -> None:
        t0 = time.perf_counter()
        self.sim.step(tau)
        self.step_times.append(time.perf_counter() - t0)

    def measure(self) -> tuple[np.ndarray, np.ndarray]:
        return self.sim.measure()

    def push(self, frame: str, force, start: float, duration: float) -> None:
        self.sim.push(frame, force, start, duration)

    def point_positions(self) -> np.ndarray:
        return self.sim.point_positions()

    def contact_wrench(self, frame: str) -> np.ndarray:
        return self.sim.contact_wrench(frame)

    def com(self) -> np.ndarray:
        return self.sim.com()


def sim_loop(scenario: str = "talos_balance", duration: float = 3.0, solvers=("hqp", "projection")) -> dict:
    """The closed loop of ``wbc run <scenario> --headless`` for ``duration`` s simulated,
    per solver: ``real_time_factor``, ``fell``, ``controller_median_ms`` and
    ``simulator_median_ms`` (median per cycle)."""
    path = SCENARIOS_DIR / f"{scenario}.yaml"
    out = {"scenario": scenario, "duration_s": duration}
    for solver in solvers:
        sc = load_config(path)
        timed: list[TimedSimulator] = []

        def wrap(sim: PhysicsSimulator, _timed=timed) -> TimedSimulator:
            _timed.append(TimedSimulator(sim))
            return _timed[-1]

        m = run_scenario(sc, solver=solver, duration=duration, wrap_simulator=wrap)
        out[solver] = {"real_time_factor": m["real_time_factor"], "fell": m["fell"],
                       "controller_median_ms": m["cycle_time"]["median"] * 1e3,
                       "simulator_median_ms": float(np.median(timed[0].step_times) * 1e3)}
    return out
