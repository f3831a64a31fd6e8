"""Alternated rounds in one process: wbc hqp (the bench's Talos stack and trajectory) and PlaCo's
DynamicsSolver (pinocchio 3.8 environment), medians per round and their ratio.

    PYTHONPATH=. python benchmarks/peer_pair.py [ROUNDS] [CYCLES]
"""

from __future__ import annotations

import sys
import warnings

from benchmarks.harness import peers, stacks, timing
from wbc.robots import load_robot


def main(rounds: int = 3, cycles: int = 2000) -> None:
    warnings.simplefilter("ignore")
    robot = load_robot("talos")
    for r in range(rounds):
        w = timing.run_case(robot, stacks.talos_stack, "hqp", "daqp", cycles, 200, phases=False)
        p = peers.placo_dynamics(robot, cycles, 200)
        wm, pm = w["median_ms"], p["solve"]["median_ms"]
        print(f"round {r}: wbc hqp median {wm:.3f} ms (p99 {w['p99_ms']:.3f}), PlaCo solve median {pm:.3f} ms, "
              f"ratio {wm / pm:.2f}, QPs/cycle {w['qp_per_cycle']:.2f}", flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
