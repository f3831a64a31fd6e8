"""Where one velocity-mode solve spends its time: the Talos IK problem of ``ik_peers.py``.

    PYTHONPATH=. python benchmarks/velocity_profile.py [--rounds N] [--cprofile]

Prints the median per phase (µs) of ``VelocityController.solve`` at q0, the phases timed by
``perf_counter_ns`` around the steps the controller takes (the controller's ``phase_times``
hook, :meth:`wbc.controller.velocity.VelocityController.solve`), and the whole solve's
median timed without the splits. ``--cprofile``: the top functions by total time over the
rounds (cProfile's own overhead inflates every Python call; read it for where, not how much).
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import time
import warnings

import numpy as np

from benchmarks.ik_peers import Problem, WbcIK
from wbc.robot.loader import load_robot


def split(ctrl, q) -> dict[str, int]:
    """One solve, step by step as ``VelocityController._solve`` takes them, each step timed (ns)."""
    from functools import partial

    import pinocchio as pin

    from wbc.controller.velocity import VelocitySolution, _equality_diagnostics
    from wbc.controller.velocity_step import ACCEPTED

    t, ns = {}, time.perf_counter_ns
    t0 = ns()
    robot = ctrl.robot
    v = np.zeros(robot.nv)
    ctrl.faults.state_fault(q, v)
    q, v = robot.check_state(q, v, finite=False)
    t1 = ns()
    t["fault checks, state checks"] = t1 - t0
    robot.update_kinematics(q, v)
    t2 = ns()
    t["pinocchio update (computeJointJacobians, frames, J_com)"] = t2 - t1
    groups = ctrl.groups()
    plan = ctrl._plan
    key = (ctrl.stack.version, len(groups), *map(len, groups))
    assert plan.matches(groups, key)
    t3 = ns()
    t["plan check"] = t3 - t2
    out = plan.fill_step(ctrl.solver, ctrl.dt)    # the rows and the equality-only cascade in one call
    assert out is not None and out is not False and out[0] == ACCEPTED, \
        "the one call did not answer: the phases below are not the cycle's"
    t4 = ns()
    t["rows and solver (VelocityPlan.fill_step: the Python checks, then one call: the rows, the equality-only "
      "cascade, q̇'s finite check, the rows' values, q̇ dt)"] = t4 - t3
    nv = robot.nv
    qd = out[3][:nv]
    evaluate = partial(_equality_diagnostics, plan, out, (ctrl.sacrifice_tol, ctrl.sacrifice_rel))
    t6 = ns()
    t["bookkeeping (diagnostics closure)"] = t6 - t4
    q_next = pin.integrate(robot.model, q, plan.step)
    t7 = ns()
    t["integration (pin.integrate)"] = t7 - t6
    VelocitySolution.accepted(qd, q_next, robot.na, evaluate)
    t["solution object"] = ns() - t7
    return t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=2000)
    ap.add_argument("--cprofile", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    robot = load_robot("talos")
    pb = Problem(robot)
    ik = WbcIK(pb)
    ctrl = ik.ctrl
    for _ in range(50):
        ik.timed()
    whole = np.empty(args.rounds)
    for r in range(args.rounds):
        t0 = time.perf_counter_ns()
        ik.timed()
        whole[r] = time.perf_counter_ns() - t0
    print(f"load {os.getloadavg()[0]:.2f}; whole solve median {np.median(whole) / 1e3:.1f} µs "
          f"(p10 {np.percentile(whole, 10) / 1e3:.1f}, p90 {np.percentile(whole, 90) / 1e3:.1f})")
    phases: dict[str, list[float]] = {}
    for _ in range(args.rounds):
        for k, v in split(ctrl, ik.q).items():
            phases.setdefault(k, []).append(v)
    total = 0.0
    print("| phase | median (µs) |\n|---|---|")
    for k, v in phases.items():
        m = float(np.median(v)) / 1e3
        total += m
        print(f"| {k} | {m:.1f} |")
    print(f"| sum of the medians | {total:.1f} |")
    if args.cprofile:
        pr = cProfile.Profile()
        pr.enable()
        for _ in range(args.rounds):
            ik.timed()
        pr.disable()
        pstats.Stats(pr).sort_stats("tottime").print_stats(25)


if __name__ == "__main__":
    main()
