"""Where the compiled cascade's time goes, level by level, on the Talos bench (hqp).

    PYTHONPATH=. python benchmarks/cascade_levels.py [--cycles 800] [--reps 5]

Runs the bench trajectory (``benchmarks.harness``: the moving CoM and hand targets, the 5-level
Talos stack, 200 warm-up cycles), captures the arguments of every call of the compiled run
(:func:`wbc.solvers.kernels.cascade_run.cascade_prefix_profiled`, the hqp's torque cycle since
level 0 is factored within its rows' profiles) and replays
them cut after level k (the levels' row ends truncated), ``--reps`` times each: the median
thread CPU time per call, cumulative, and how many of the captured cycles solved a certified
QP at each level. The route hints are copied per call, so each replay starts from the state
the cycle had.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np


def capture(cycles: int) -> list:
    import pinocchio as pin

    import wbc
    import wbc.solvers.hqp_planned as hp
    from benchmarks.harness import stacks, trajectory

    warnings.simplefilter("ignore")
    calls: list = []
    run = hp.cascade_prefix_profiled

    def kept(eq, ineq, start, hints, settings):
        calls.append((eq, ineq, start, hints.copy(), settings))
        out = run(eq, ineq, start, hints, settings)
        calls[-1] = tuple(_copied(a) for a in calls[-1])      # the buffer is refilled next cycle
        return out

    hp.cascade_prefix_profiled = kept
    robot = wbc.load_robot("talos")
    stack = stacks.talos_stack()
    ctrl = wbc.Controller(robot, stack, solver="hqp", backend="daqp")
    ctrl._profiled.enabled = False          # the solver's entry: the run called from Python (the same run)
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    targets = trajectory.moving_targets(robot, stack, ("right_hand", "left_hand"))
    for k in range(cycles + 200):
        targets(k * trajectory.DT)
        if k == 200:
            calls.clear()
        sol = ctrl.solve(q, v)
        v = v + sol.qdd * trajectory.DT
        q = pin.integrate(robot.model, q, v * trajectory.DT)
    hp.cascade_prefix_profiled = run
    return calls


def _copied(a):
    if isinstance(a, tuple):
        return tuple(_copied(b) for b in a)
    return a.copy() if isinstance(a, np.ndarray) else a


def main() -> None:
    from wbc.solvers.kernels.cascade_run import cascade_prefix_profiled as cascade_prefix
    from wbc.solvers.kernels.records import CERTIFIED, LEVEL_INTS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=800)
    ap.add_argument("--reps", type=int, default=5)
    args = ap.parse_args()
    calls = capture(args.cycles)
    L = calls[0][0][2].shape[0]
    qps = np.zeros(L, dtype=int)
    for c in calls:
        out = cascade_prefix(c[0], c[1], c[2], c[3].copy(), c[4])
        qps += [out[4][LEVEL_INTS * k + CERTIFIED] > 0 for k in range(L)]
    print(f"{len(calls)} cycles captured; median thread CPU µs of the run cut after each level:")
    for cut in range(L + 1):
        cs = [((A, b, e_end[:cut]), (C, lo, hi, i_end[:cut]), start, hints, settings)
              for (A, b, e_end), (C, lo, hi, i_end), start, hints, settings in calls]
        for c in cs[:20]:
            cascade_prefix(c[0], c[1], c[2], c[3].copy(), c[4])
        ts = []
        for _ in range(args.reps):
            for c in cs:
                hints = c[3].copy()
                t0 = time.thread_time_ns()
                cascade_prefix(c[0], c[1], c[2], hints, c[4])
                ts.append(time.thread_time_ns() - t0)
        what = "no level" if cut == 0 else f"levels 0..{cut - 1}"
        share = "" if cut == 0 else f"   (level {cut - 1}: certified QP in {100 * qps[cut - 1] / len(calls):.0f} % of cycles)"
        print(f"  {what:12s} {np.median(ts) / 1e3:7.1f}{share}")


if __name__ == "__main__":
    main()
