"""A closed loop's real-time factor in thread CPU time and in wall time, and the control cycle's
spread in both (#26). Run it on each tree with that tree on PYTHONPATH, alternated:

    PYTHONPATH=TREE python benchmarks/loop_rtf.py [SCENARIO] [SIMULATOR] [DURATION]
        (talos_balance, pinocchio, the scenario's duration; hqp, one OpenBLAS thread as `wbc run`)

From the second cycle on (the first loads the kernels): simulated time over the loop's thread CPU
time (what the code costs, whatever else the machine runs) and over its wall time (what
`wbc run` reports as ``real_time_factor``); per cycle, ``Controller.solve``'s wall time (the
metrics' ``cycle_time``) and its thread CPU time (which leaves out the time the thread was
preempted): median, p99 and p99/median; the whole cycle's thread time median. One line.
"""

from __future__ import annotations

import os
import sys
import time
import warnings

import numpy as np

from wbc.blas import blas_threads
from wbc.controller.cycle import Controller
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config


def main(scenario: str = "talos_balance", simulator: str = "pinocchio", duration: str | None = None) -> None:
    warnings.simplefilter("ignore")
    solve_cpu: list[int] = []
    solve = Controller.solve

    def timed(self, *a, **k):
        c0 = time.thread_time_ns()
        out = solve(self, *a, **k)
        solve_cpu.append(time.thread_time_ns() - c0)
        return out

    Controller.solve = timed         # type: ignore[method-assign]
    try:
        settings = {} if duration is None else {"duration": float(duration)}
        r = ScenarioRun(load_config(scenario), solver="hqp", simulator=simulator, **settings)
        cycle_cpu = np.zeros(r.n, dtype=np.int64)
        with blas_threads(1):
            r.cycle(0)
            c_start, w_start = time.thread_time_ns(), time.perf_counter_ns()
            done = 1
            for k in range(1, r.n):
                c0 = time.thread_time_ns()
                ok = r.cycle(k)
                cycle_cpu[k] = time.thread_time_ns() - c0
                done += 1
                if not ok:
                    break
            cpu, wall = time.thread_time_ns() - c_start, time.perf_counter_ns() - w_start
    finally:
        Controller.solve = solve     # type: ignore[method-assign]
    simulated = (done - 1) * r.sc.dt * 1e9
    sw = r.cycle_times[1:done] * 1e6
    sc = np.array(solve_cpu[1:done]) / 1e3

    def spread(x: np.ndarray) -> str:
        med, p99 = np.median(x), np.percentile(x, 99)
        return f"median {med:6.0f} p99 {p99:6.0f} ({p99 / med:.2f}×)"

    load = os.getloadavg()[0]
    print(f"{scenario} {simulator} load {load:.1f}: RTF thread {simulated / cpu:.3f} wall {simulated / wall:.3f} | "
          f"solve wall µs {spread(sw)} | solve thread µs {spread(sc)} | cycle thread µs median "
          f"{np.median(cycle_cpu[1:done]) / 1e3:6.0f} | {done} cycles")


if __name__ == "__main__":
    main(*sys.argv[1:4])
