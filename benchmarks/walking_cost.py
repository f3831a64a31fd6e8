"""A/B in one process (issue #24): the walking cycle (the walker's update: phase, replan,
references, contact switches; plus the controller's solve) against the standing cycle (the
same stack's solve without the walk), interleaved in blocks of cycles on two closed loops of
``talos_walk`` (one with its walk, one standing), thread CPU time; and the replans' time.

    PYTHONPATH=. python benchmarks/walking_cost.py [SECONDS] [SIMULATOR]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from wbc.runner.loop import ScenarioRun
from wbc.runner.walking import WalkObserver
from wbc.scenario.loader import load_config


def _timed(fn, out: list):
    def wrapper(*args, **kwargs):
        t0 = time.thread_time()
        r = fn(*args, **kwargs)
        out.append(time.thread_time() - t0)
        return r
    return wrapper


def main(seconds: float = 4.0, simulator: str = "pinocchio", block: int = 50) -> None:
    warnings.simplefilter("ignore")
    runs, solve, walker, after = {}, {"walk": [], "stand": []}, [], []
    for name in ("walk", "stand"):
        sc = load_config("talos_walk")
        if name == "stand":
            sc.walk = None
        r = ScenarioRun(sc, simulator=simulator, duration=seconds, progress=False)
        r.ctrl.solve = _timed(r.ctrl.solve, solve[name])          # type: ignore[method-assign]
        for o in r.observers:
            if isinstance(o, WalkObserver):
                o.before_solve = _timed(o.before_solve, walker)   # type: ignore[method-assign]
                o.after_step = _timed(o.after_step, after)         # type: ignore[method-assign]
                runs["observer"] = o
        runs[name] = r
    n = runs["walk"].n
    for k0 in range(0, n, block):
        for name in ("walk", "stand"):
            for k in range(k0, min(k0 + block, n)):
                if not runs[name].cycle(k):
                    raise SystemExit(f"{name} run ended at cycle {k}")
    skip = 1           # the first cycle loads the kernels
    w, s, u = np.array(solve["walk"][skip:]), np.array(solve["stand"][skip:]), np.array(walker[skip:])
    a = np.array(after[skip:])
    cycle = w + u
    replans = np.array(runs["observer"].walker.preview.replan_times)
    steps = len(runs["observer"].walker.touchdowns)
    print(f"talos_walk, {simulator}, {seconds:g} s ({n} cycles, {steps} touch-downs), interleaved blocks of {block}")
    print(f"standing cycle (solve)          median {np.median(s) * 1e3:.3f} ms   p90 {np.percentile(s, 90) * 1e3:.3f} ms")
    print(f"walking cycle (solve + walker)  median {np.median(cycle) * 1e3:.3f} ms   p90 "
          f"{np.percentile(cycle, 90) * 1e3:.3f} ms")
    print(f"  of which the walker           median {np.median(u) * 1e3:.3f} ms   p90 {np.percentile(u, 90) * 1e3:.3f} ms")
    print(f"ratio walking/standing (medians) {np.median(cycle) / np.median(s):.2f}")
    print(f"the walk's measurement after the step (metrics, view data; not in the cycle above)  median "
          f"{np.median(a) * 1e3:.3f} ms   p90 {np.percentile(a, 90) * 1e3:.3f} ms")
    print(f"replan (wall time, {len(replans)})  median {np.median(replans) * 1e3:.3f} ms   max {replans.max() * 1e3:.3f} ms")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 4.0, sys.argv[2] if len(sys.argv) > 2 else "pinocchio")
