"""Where a talos_balance closed-loop cycle (hqp, 2 s) goes: thread CPU time medians (µs) of the
controller, the simulator's step and measure (MuJoCo: its state and contact read-outs inside the
step), the runner's metrics, references and checks (``step_checks``: the divergence and the fall
in one call, where the tree has it), and the whole cycle; ``rest`` is the cycle
less the pieces timed directly in it (the loop's own Python, the trajectory samples, the timers'
own cost, about 2 µs a timed call) (#26).

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
from wbc.sim.simulator import Simulator
from wbc.tasks.com import CoM

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
    pieces = [(metrics.RunMetrics, "record_state", "metrics.record_state"),
              (metrics.RunMetrics, "record_command", "metrics.record_command"),
              (Controller, "solve", "controller.solve"), (Simulator, "step", "sim.step"),
              (Simulator, "measure", "sim.measure"),
              (metrics.RunMetrics, "record_singular", "metrics.record_singular"),
              (CoM, "set_reference", "com.set_reference"), (loop, "simulation_diverged", "simulation_diverged"),
              (loop, "fallen", "fallen"), (loop, "step_checks", "step_checks"), (loop.ScenarioRun, "cycle", "cycle")]
    if simulator == "mujoco":  # imported only here: the peer environment (pinocchio 3.8) has no MuJoCo
        from wbc.sim.mujoco_sim import MujocoSimulator

        pieces += [(MujocoSimulator, "step", "mujoco.step"), (MujocoSimulator, "measure", "sim.measure"),
                   (MujocoSimulator, "_read_state", "(mujoco._read_state)"),
                   (MujocoSimulator, "_read_contacts", "(mujoco._read_contacts)")]
    for cls, name, key in pieces:
        if hasattr(cls, name):      # (a piece another tree does not have: this script runs on either)
            timed(cls, name, key)
    loop.run(load_config(SCENARIOS_DIR / "talos_balance.yaml"), solver="hqp", duration=2.0, simulator=simulator)
    med = {k: np.median(x[50:]) / 1e3 for k, x in TIMES.items()}
    for k, m in med.items():
        print(f"{k:24s} {m:7.1f} µs")
    print(f"{'rest':24s} {med['cycle'] - sum(m for k, m in med.items() if k != 'cycle' and k[0] != '('):7.1f} µs")


if __name__ == "__main__":
    main(*sys.argv[1:2])
