"""Where a scenario's control-cycle tail comes from (#26, target 3): each cycle's wall and
thread CPU time of ``Controller.solve``, whether the thread was preempted in it or in the cycle
before (involuntary context switches, ``getrusage(RUSAGE_THREAD)``: after another process ran,
the caches are cold), whether Python's collector ran, the minor page faults (an allocator that
maps fresh memory) and the QPs the cycle solved (uneven work), and, over
RUNS runs of the same scenario in one process, whether the same cycles are slow every time
(then the work is uneven) or not (then the machine is).

    PYTHONPATH=. python benchmarks/cycle_tail.py [SCENARIO] [RUNS]      (talos_reach, 3; Linux)
"""

from __future__ import annotations

import gc
import resource
import sys
import time
import warnings

import numpy as np

from wbc.controller.cycle import Controller
from wbc.runner import loop
from wbc.scenario.loader import load_config


def one_run(scenario: str) -> tuple[np.ndarray, ...]:
    """(wall µs, thread µs, involuntary switches, gc runs, minor faults, QPs) per cycle, the
    first left out."""
    wall, cpu, sw, gcs, flt, qps = [], [], [], [], [], []
    collections = [0]

    def counted(phase, info):
        collections[0] += phase == "start"

    solve = Controller.solve

    def timed(self, *a, **k):
        ru, g0 = resource.getrusage(resource.RUSAGE_THREAD), collections[0]
        t0, c0 = time.perf_counter_ns(), time.thread_time_ns()
        out = solve(self, *a, **k)
        cpu.append(time.thread_time_ns() - c0)
        wall.append(time.perf_counter_ns() - t0)
        after = resource.getrusage(resource.RUSAGE_THREAD)
        sw.append(after.ru_nivcsw - ru.ru_nivcsw)
        flt.append(after.ru_minflt - ru.ru_minflt)
        gcs.append(collections[0] - g0)
        qps.append(out.qp_count)
        return out

    gc.callbacks.append(counted)
    Controller.solve = timed
    try:
        loop.run(load_config(scenario), solver="hqp")
    finally:
        Controller.solve = solve
        gc.callbacks.remove(counted)
    return (np.array(wall[1:]) / 1e3, np.array(cpu[1:]) / 1e3, np.array(sw[1:]), np.array(gcs[1:]), np.array(flt[1:]),
            np.array(qps[1:]))


def ratio(x: np.ndarray) -> str:
    return f"median {np.median(x):7.1f} µs, p99 {np.percentile(x, 99):7.1f} ({np.percentile(x, 99) / np.median(x):.2f}×)"


def main(scenario: str = "talos_reach", runs: int = 3) -> None:
    warnings.simplefilter("ignore")
    got = [one_run(scenario) for _ in range(runs)]
    for i, (wall, cpu, sw, gcs, flt, qps) in enumerate(got):
        tail = wall >= np.percentile(wall, 99)
        calm = sw == 0
        after = calm & (np.r_[0, sw[:-1]] > 0)          # not preempted itself, the cycle before was
        calm_tail = calm & (wall >= np.percentile(wall[calm], 99))
        print(f"run {i}: wall {ratio(wall)}; thread {ratio(cpu)}; cycles preempted {int((sw > 0).sum())} of "
              f"{wall.size}, of the wall tail {int((tail & (sw > 0)).sum())} of {int(tail.sum())}; "
              f"collector runs {int(gcs.sum())}; wall without preemption {ratio(wall[calm])}, of its tail "
              f"{int((calm_tail & after).sum())} of {int(calm_tail.sum())} right after a preempted cycle, "
              f"{int((calm_tail & (gcs > 0)).sum())} with a collection, {int((calm_tail & (flt > 0)).sum())} with a "
              f"page fault, {int((calm_tail & (qps > 0)).sum())} with a QP (cycles with a QP: {int((qps > 0).sum())})")
    n = min(g[0].size for g in got)
    cpu = np.array([g[1][:n] for g in got])
    clean = np.ones(n, bool)
    for g in got:                    # no switch in the cycle nor in the one before it
        s = g[2][:n] > 0
        clean &= ~s & ~np.r_[False, s[:-1]]
    logs = np.log(cpu[:, clean])
    corr = [float(np.corrcoef(logs[i], logs[i + 1])[0, 1]) for i in range(runs - 1)]
    print(f"{int(clean.sum())} cycles never preempted: correlation of their thread times between runs "
          f"{', '.join(f'{c:.2f}' for c in corr)}; per-cycle minimum over the runs {ratio(cpu[:, clean].min(0))}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "talos_reach", int(sys.argv[2]) if len(sys.argv) > 2 else 3)
