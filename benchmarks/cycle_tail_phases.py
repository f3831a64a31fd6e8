"""Where the tail cycles of a closed loop spend their extra time (#26, target 3): per cycle, the
thread CPU time of each phase of ``Controller.solve`` (entry: the fault monitor and the state
check; update: ``RobotModel.update``; rows: the stack's rows; prep: the reference point and the
``Problem``; solve: the solver; finish: τ and the ``Solution``; exit: the fault monitor's
bookkeeping), of the rest of the loop's cycle (the simulator's step, the metrics), and of two
*probes*, a fixed chain of dependent floating-point operations (no memory traffic, the same
instructions every time) run right before and right after the solve. A probe slower than its
median says the core itself ran slower at that moment (the host's frequency, a hyperthread
sibling, interrupts), whatever wbc's code did.

From cycle 10 on (the first cycles load kernels), for the cycles in the top 1 % of the solve's
thread time (leaving out those preempted or right after a preemption): each phase's excess over
its own median as a share of the cycle's excess, beside its share of the median cycle (equal
shares: the whole cycle ran slower; one phase far above its share: that phase carries the tail),
and the probes' slowdown in the tail cycles and in the others. ``--minimum`` reads runs saved with
``--save`` and gives each phase's spread of the per-cycle minimum over them (the work's own), the
cycles of its top 1 %, and per period P the residue class k mod P slowest in the median (work done
every P cycles).

    PYTHONPATH=. python benchmarks/cycle_tail_phases.py [SCENARIO] [--cpu N] [--gc-freeze] [--save F.npz]
        (talos_reach, own simulator, hqp, one OpenBLAS thread; Linux)
    PYTHONPATH=. python benchmarks/cycle_tail_phases.py --minimum A.npz B.npz C.npz
"""

from __future__ import annotations

import argparse
import gc
import os
import resource
import sys
import time
import warnings

import numba
import numpy as np

from wbc.blas import blas_threads
from wbc.controller.cycle import Controller
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config

PHASES = ("entry", "update", "rows", "prep", "solve", "finish", "exit")
#: the periods ``--minimum`` looks for periodic work at (cycles)
PERIODS = (2, 5, 10, 20, 50, 100, 200, 500)
#: cycles left out of the figures (and of the saved arrays, whose row i is cycle WARM + i)
WARM = 10


@numba.njit(cache=False)
def _chain(n: int, x: float) -> float:      # pragma: no cover - compiled
    """n dependent multiply-adds: a fixed amount of pure arithmetic."""
    for _ in range(n):
        x = x * 0.9999999 + 1e-7
    return x


class Stamps:
    """A ``phase_clock`` writing each lap's thread time into the current cycle's row."""

    def __init__(self, n: int) -> None:
        self.t = np.zeros((n, 8), dtype=np.int64)      # entry, 6 laps, exit
        self.k, self.j = 0, 1

    def lap(self, name: str | None, t0: int) -> int:
        now = time.thread_time_ns()
        self.t[self.k, self.j] = now
        self.j += 1
        return now


def minimum(files: list[str]) -> None:
    """Per phase, the p99/median of each cycle's minimum over the runs saved in ``files`` (the
    same scenario: the same work cycle for cycle): what is left of the spread when the
    machine's moments are filtered out, i.e. the work's own unevenness; and the cycles whose
    minimum is above 1.3× its median (work that is longer every run)."""
    ph = np.array([np.load(f)["phases"] for f in files])
    saved = np.load(files[0])
    first = int(saved["first"]) if "first" in saved.files else 1
    n = min(p.shape[0] for p in ph)
    low = ph[:, :n].min(0)
    total = low.sum(1)
    print(f"minimum over {len(files)} runs: solve p99/median {np.percentile(total, 99) / np.median(total):.3f}")
    for i, name in enumerate(PHASES):
        x = low[:, i]
        print(f"  {name:10s} median {np.median(x):7.1f} µs, p99/median {np.percentile(x, 99) / np.median(x):.2f}")
    slow = np.flatnonzero(total > 1.3 * np.median(total)) + first
    print(f"  cycles whose minimum is above 1.3× the median: {slow.size}, the first {slow[:20].tolist()}")
    top = np.sort(np.argsort(total)[::-1][:max(1, n // 100)] + first)
    print(f"  the top 1 % of the minimum (cycles): {top.tolist()}")
    # periodic work: per period P, the residue class k mod P whose median is furthest above the median
    # (#26, tail2: the support polygon's Qhull every 50 cycles left cycle 50 j + 1 1.09× the median)
    k = np.arange(n) + first
    for p in PERIODS:
        ratio = [np.median(total[k % p == r]) / np.median(total) for r in range(p)]
        r = int(np.argmax(ratio))
        print(f"  period {p:4d}: cycles k ≡ {r} (mod {p}) median {ratio[r]:.3f}× the median")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario", nargs="?", default="talos_reach")
    ap.add_argument("--simulator", default="pinocchio")
    ap.add_argument("--cpu", type=int, default=None, help="pin the loop's thread to this core")
    ap.add_argument("--gc-freeze", action="store_true", help="gc.freeze() after the set-up")
    ap.add_argument("--probe-us", type=float, default=15.0)
    ap.add_argument("--save", default=None)
    ap.add_argument("--minimum", nargs="+", metavar="F.npz", help="no run: the per-cycle minimum over saved runs")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    if a.minimum:
        minimum(a.minimum)
        return
    if a.cpu is not None:
        os.sched_setaffinity(0, {a.cpu})
    r = ScenarioRun(load_config(a.scenario), solver="hqp", simulator=a.simulator)
    n = r.n
    st = Stamps(n)
    probe = np.zeros((n, 2), dtype=np.int64)
    rest = np.zeros(n, dtype=np.int64)
    sw = np.zeros(n, dtype=np.int64)
    flt = np.zeros(n, dtype=np.int64)
    gcs = np.zeros(n, dtype=np.int64)
    blocks = np.zeros(n, dtype=np.int64)
    collections = [0]
    gc.callbacks.append(lambda phase, info: collections.__setitem__(0, collections[0] + (phase == "start")))
    # the probe's length: the median of 51 warm calls of 10⁴ operations
    _chain(10, 1.0)
    one = []
    for _ in range(51):
        c0 = time.thread_time_ns()
        _chain(10_000, 1.0)
        one.append(time.thread_time_ns() - c0)
    m_probe = max(1, int(a.probe_us * 1e3 / np.median(one) * 10_000))
    solve = Controller.solve

    def timed(self, *args, **kw):
        k = st.k
        c0 = time.thread_time_ns()
        _chain(m_probe, 1.0)
        t0 = time.thread_time_ns()
        probe[k, 0] = t0 - c0
        ru, g0, b0 = resource.getrusage(resource.RUSAGE_THREAD), collections[0], sys.getallocatedblocks()
        st.j = 1
        st.t[k, 0] = time.thread_time_ns()
        out = solve(self, *args, **kw)
        st.t[k, 7] = time.thread_time_ns()
        after = resource.getrusage(resource.RUSAGE_THREAD)
        blocks[k] = sys.getallocatedblocks() - b0
        sw[k] = after.ru_nivcsw - ru.ru_nivcsw
        flt[k] = after.ru_minflt - ru.ru_minflt
        gcs[k] = collections[0] - g0
        c1 = time.thread_time_ns()
        _chain(m_probe, 1.0)
        probe[k, 1] = time.thread_time_ns() - c1
        return out

    Controller.solve = timed     # type: ignore[method-assign]
    r.ctrl.phase_clock = st
    try:
        with blas_threads(1):
            r.cycle(0)
            if a.gc_freeze:
                gc.collect()
                gc.freeze()
            done = 1
            for k in range(1, n):
                st.k = k
                c0 = time.thread_time_ns()
                ok = r.cycle(k)
                rest[k] = time.thread_time_ns() - c0
                done += 1
                if not ok:
                    break
    finally:
        Controller.solve = solve     # type: ignore[method-assign]
    w = WARM     # the first cycles load the kernels of the branches cycle 0 did not take: left out
    t = st.t[w:done].astype(float) / 1e3
    ph = np.diff(t, axis=1)                       # (cycles, 7) µs
    total = t[:, 7] - t[:, 0]
    pr = probe[w:done].astype(float) / 1e3
    rest_us = rest[w:done] / 1e3 - total - pr.sum(1)
    s = sw[w:done] > 0
    calm = ~s & ~np.r_[False, s[:-1]]
    med_total = np.median(total)
    p99 = np.percentile(total, 99)
    tail = calm & (total >= np.percentile(total[calm], 99))
    med_ph = np.median(ph[calm], axis=0)
    excess = ph[tail] - med_ph
    share_tail = excess.sum(0) / excess.sum()
    load = os.getloadavg()[0]
    print(f"{a.scenario} load {load:.1f} cpu {a.cpu} gc_freeze {a.gc_freeze}: solve thread median {med_total:.1f} "
          f"p99 {p99:.1f} ({p99 / med_total:.2f}×); not preempted "
          f"{np.percentile(total[calm], 99) / np.median(total[calm]):.2f}×; "
          f"{int(s.sum())} of {done - w} preempted; blocks allocated per solve median "
          f"{np.median(blocks[w:done]):.0f}; minor faults {int(flt[w:done].sum())}, collections {int(gcs[w:done].sum())}")
    print("  phase        median µs  share of median  share of tail excess  tail/median")
    for i, name in enumerate(PHASES):
        print(f"  {name:10s} {med_ph[i]:10.1f} {med_ph[i] / med_ph.sum():14.2f} {share_tail[i]:20.2f} "
              f"{np.mean(ph[tail, i]) / med_ph[i]:12.2f}")
    pm = np.median(pr[calm], axis=0)
    rel = pr / pm
    print(f"  probes ({pm[0]:.1f} µs): before/after the solve, tail cycles {np.mean(rel[tail, 0]):.3f} / "
          f"{np.mean(rel[tail, 1]):.3f}, others {np.mean(rel[calm & ~tail, 0]):.3f} / {np.mean(rel[calm & ~tail, 1]):.3f}; "
          f"probe p99/median {np.percentile(pr[calm, 0], 99) / pm[0]:.2f}×; corr(log solve, log mean probe) "
          f"{np.corrcoef(np.log(total[calm]), np.log(rel[calm].mean(1)))[0, 1]:.2f}")
    print(f"  rest of the loop's cycle median {np.median(rest_us[calm]):.1f} µs, p99/median "
          f"{np.percentile(rest_us[calm], 99) / np.median(rest_us[calm]):.2f}×; in the tail cycles "
          f"{np.mean(rest_us[tail]) / np.median(rest_us[calm]):.2f}× its median")
    if a.save:
        np.savez(a.save, phases=ph, probes=pr, rest=rest_us, switches=sw[w:done], faults=flt[w:done],
                 collections=gcs[w:done], blocks=blocks[w:done], first=w)


if __name__ == "__main__":
    main()
