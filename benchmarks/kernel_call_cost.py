"""What grouping a kernel's arguments in tuples costs per call (numba dispatch), measured on a
real kernel: ``JointLimits``' ``acceleration_bounds`` (13 flat arguments) against the same
kernel behind a compiled wrapper taking (q, v, index, limits, settings) as tuples, on TIAGo.

    python benchmarks/kernel_call_cost.py [--calls 50000]

Prints the best of 5 repeats of each, per call (µs of the thread's CPU time). The figures are
in benchmarks/layout_ab.md.
"""

from __future__ import annotations

import argparse
import time
import timeit

import numba as nb
import numpy as np

import wbc
from wbc.tasks.joint_limits import acceleration_bounds


@nb.njit(cache=False)
def grouped(q, v, index, limits, settings):
    """acceleration_bounds with its arguments in three tuples."""
    qi, vi, extra, _ = index
    qmax, qmin, vmax, vmax_extra = limits
    margin, dt, horizon, amax = settings
    return acceleration_bounds(q, v, qi, vi, qmax, qmin, vmax, margin, dt, horizon, amax, extra, vmax_extra)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--calls", type=int, default=50000)
    n = ap.parse_args().calls
    robot = wbc.load_robot("tiago")
    task = wbc.tasks.JointLimits()
    (qi, vi, extra, idx), (qmax, qmin, vmax, vx) = task.coordinates(robot)
    index, limits = (qi, vi, extra, idx), (qmax, qmin, vmax, vx)
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    m, dt, hz, amax = task.margin, task.dt, task.horizon, task.max_acceleration

    def flat():
        return acceleration_bounds(q, v, qi, vi, qmax, qmin, vmax, m, dt, hz, amax, extra, vx)

    def tuples():
        return grouped(q, v, index, limits, (m, dt, hz, amax))

    for f in (flat, tuples):
        f()
    a, b = flat(), tuples()
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    for name, f in (("flat (13 arguments)", flat), ("grouped (5, three tuples)", tuples)):
        best = min(timeit.Timer(f, timer=time.thread_time).repeat(5, n)) / n
        print(f"{name}: {best * 1e6:.2f} µs per call")


if __name__ == "__main__":
    main()
