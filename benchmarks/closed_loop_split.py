"""Where a talos_balance closed-loop cycle (hqp, 2 s) goes: thread CPU time medians (µs) of the
controller, the simulator's step and measure, the runner's metrics and the whole cycle (#26).

    PYTHONPATH=. python benchmarks/closed_loop_split.py [pinocchio|mujoco]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from wbc.controller.cycle import Controller
from wbc.runner import loop, metrics
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config
from wbc.sim.mujoco_sim import MujocoSimulator
from wbc.sim.simulator import Simulator

TIMES: dict[str, list[int]] = {}


def timed(cls, name: str, key: str) -> None:
    f = getattr(cls, name)

    def wrapper(*a, **k):
        t0 = time.thread_time_ns()
        out = f(*a, **k)
        TIMES.setdefault(key, []).append(time.thread_time_ns() - t0)
        return out

    setattr(cls, name, wrapper)


def main(simulator: str = "pinocchio") -> None:
    warnings.simplefilter("ignore")
    for cls, name, key in ((metrics.RunMetrics, "record_state", "metrics.record_state"),
                           (metrics.RunMetrics, "record_command", "metrics.record_command"),
                           (Controller, "solve", "controller.solve"), (Simulator, "step", "sim.step"),
                           (MujocoSimulator, "step", "mujoco.step"), (loop.ScenarioRun, "cycle", "cycle")):
        timed(cls, name, key)
    loop.run(load_config(SCENARIOS_DIR / "talos_balance.yaml"), solver="hqp", duration=2.0, simulator=simulator)
    for k, x in TIMES.items():
        print(f"{k:24s} {np.median(x[50:]) / 1e3:7.1f} µs")


if __name__ == "__main__":
    main(*sys.argv[1:2])
