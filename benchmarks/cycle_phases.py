"""The control cycle's phases on the bench trajectory, for the tree it is run from: per solver,
the median over the cycles of each phase the controller laps through its ``phase_clock``
(``update``: RobotModel.update; ``rows``: the stack's rows; ``solve``: the solver; ``finish``: τ,
status and the Solution) and of the whole ``Controller.solve``, in µs of the thread's CPU time.

    PYTHONPATH=TREE python benchmarks/cycle_phases.py [--robot tiago] [--cycles 1500]

Run it alternately in two trees (A B A B) to see where a change moved the cycle's time
(benchmarks/layout_ab.md); ``benchmarks/tree_ab.py`` times the whole cycle the same way.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

import wbc
from benchmarks.harness import stacks, trajectory


class ThreadClock:
    """A ``phase_clock``: each lap's thread CPU time, by phase name (ns)."""

    def __init__(self) -> None:
        self.laps: dict[str, list[int]] = {}

    def lap(self, name: str | None, t0: int) -> int:
        now = time.thread_time_ns()
        if name is not None:
            self.laps.setdefault(name, []).append(now - t0)
        return now


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robot", choices=("talos", "tiago"), default="tiago")
    ap.add_argument("--cycles", type=int, default=1500)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    make, circles = ((stacks.tiago_stack, ("hand",)) if args.robot == "tiago"
                     else (stacks.talos_stack, ("right_hand", "left_hand")))
    out = {}
    for solver in ("hqp", "projection", "weighted"):
        robot = wbc.load_robot(args.robot)
        stack = make()
        ctrl = wbc.Controller(robot, stack, solver=solver, backend="daqp")
        targets = trajectory.moving_targets(robot, stack, circles)
        clock = ThreadClock()

        def attach(ctrl=ctrl, clock=clock) -> None:
            ctrl.phase_clock = clock

        total = trajectory.timed_cycles(ctrl, robot, targets, args.cycles, 200, attach)
        res = {name: round(float(np.median(x)) / 1e3, 1) for name, x in clock.laps.items()}
        res["total"] = round(float(np.median(total)) / 1e3, 1)
        out[solver] = res
    print(json.dumps(out))


if __name__ == "__main__":
    main()
