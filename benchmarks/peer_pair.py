"""Alternated rounds in one process: wbc hqp (the bench's Talos stack and trajectory, with the
contacts' default 20 % CoP margin and with the CoP allowed over the whole sole as PlaCo's
planar contacts allow it) and PlaCo's DynamicsSolver (pinocchio 3.8 environment); medians per
round and their ratios.

    PYTHONPATH=. python benchmarks/peer_pair.py [ROUNDS] [CYCLES]
"""

from __future__ import annotations

import functools
import sys
import warnings

from benchmarks.harness import peers, stacks, timing
from wbc.robots import load_robot


def main(rounds: int = 3, cycles: int = 2000) -> None:
    warnings.simplefilter("ignore")
    robot = load_robot("talos")
    whole_sole = functools.partial(stacks.talos_stack, cop_margin=0.0)
    for r in range(rounds):
        w = timing.run_case(robot, stacks.talos_stack, "hqp", "daqp", cycles, 200, phases=False)
        w0 = timing.run_case(robot, whole_sole, "hqp", "daqp", cycles, 200, phases=False)
        p = peers.placo_dynamics(robot, cycles, 200)
        wm, w0m, pm = w["median_ms"], w0["median_ms"], p["solve"]["median_ms"]
        print(f"round {r}: wbc hqp median {wm:.3f} ms (p99 {w['p99_ms']:.3f}, {w['qp_per_cycle']:.2f} QPs/cycle), "
              f"whole sole {w0m:.3f} ms ({w0['qp_per_cycle']:.2f}), PlaCo solve median {pm:.3f} ms; "
              f"ratios {wm / pm:.2f} / {w0m / pm:.2f}", flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
