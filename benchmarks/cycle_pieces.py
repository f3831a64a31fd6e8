"""Where the Talos hqp cycle's time goes, piece by piece: every task's ``rows``, the row buffer's
``fill``, the stack's ``layout`` and ``assemble``, ``RobotModel.update``, the solver's entry and
its compiled run, the controller's ``_reference`` and ``_finish``, each wrapped in a timer of
the thread's CPU time, along the bench trajectory (the bench's full stack, hqp + daqp);
medians per call (µs) and calls per cycle, largest total first.

    PYTHONPATH=TREE python benchmarks/cycle_pieces.py [--cycles 1500]

The wrappers cost ~0.3 µs a call each and are in the figures of the pieces that contain
others (``_solve``, ``assemble``); compare trees by running this alternately in each
(``benchmarks/cycle_phases.py`` and ``benchmarks/tree_ab.py`` time the unwrapped cycle).
"""

from __future__ import annotations

import argparse
import functools
import time
import warnings

import numpy as np

import wbc
import wbc.tasks as tasks
from benchmarks.harness import stacks, trajectory
from wbc.controller import cycle
from wbc.problem import buffer
from wbc.robot.model import RobotModel
from wbc.solvers import hqp
from wbc.stack import Stack
from wbc.tasks.dynamics import FloatingBaseDynamics

TIMES: dict[str, list[int]] = {}


def wrap(owner, name: str, label: str | None = None) -> None:
    """Replace ``owner.name`` by a timed call of it (label: the name printed)."""
    f = getattr(owner, name, None)
    if f is None:
        return
    label = label or name

    @functools.wraps(f)
    def timed(*a, **k):
        t0 = time.thread_time_ns()
        r = f(*a, **k)
        TIMES.setdefault(label, []).append(time.thread_time_ns() - t0)
        return r

    setattr(owner, name, timed)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles", type=int, default=1500)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    for cls in (tasks.Contact, tasks.Frame, tasks.CoM, tasks.Posture, tasks.JointLimits, tasks.TorqueLimits,
                tasks.ContactWrench, FloatingBaseDynamics):
        wrap(cls, "rows", cls.__name__ + ".rows")
    wrap(buffer.RowBuffer, "fill")
    for name in ("_solve", "_reference", "_finish"):
        wrap(cycle.Controller, name)
    wrap(RobotModel, "update")
    wrap(Stack, "assemble")
    wrap(Stack, "layout")
    # not HierarchicalQP.solve: a replaced solve makes solve_planned hand over to it (hqp_planned._plain)
    wrap(hqp.HierarchicalQP, "solve_planned")
    try:                                           # the torque cycle's entry since perf22 (its compiled run's call)
        from wbc.controller import torque_step
        wrap(torque_step.ProfiledStep, "solve", "ProfiledStep.solve")
        # perf24: the run with τ and the rows' values in its call (the torque cycle's hqp entry)
        wrap(torque_step.ProfiledStep, "solve_outputs", "ProfiledStep.solve_outputs")
    except ImportError:
        pass
    wrap(hqp, "cascade_prefix", "compiled run")
    try:
        from wbc.solvers import hqp_planned
        wrap(hqp_planned, "cascade_prefix", "compiled run (planned entry)")
    except ImportError:
        pass
    robot = wbc.load_robot("talos")
    stack = stacks.talos_stack()
    ctrl = wbc.Controller(robot, stack, solver="hqp", backend="daqp")
    targets = trajectory.moving_targets(robot, stack, ("right_hand", "left_hand"))
    total = trajectory.timed_cycles(ctrl, robot, targets, args.cycles, 200, TIMES.clear)
    print(f"{'Controller.solve':34s} calls/cycle 1.0  median {np.median(total) / 1e3:7.1f} µs")
    for name, x in sorted(TIMES.items(), key=lambda kv: -float(np.median(kv[1])) * len(kv[1])):
        print(f"{name:34s} calls/cycle {len(x) / args.cycles:3.1f}  median {np.median(x) / 1e3:7.1f} µs")


if __name__ == "__main__":
    main()
