"""A/B timing of two source trees, alternated: did a change move the control cycle's time?

    python benchmarks/tree_ab.py BEFORE_DIR AFTER_DIR [--rounds 6] [--cycles 1500] [--robots talos,tiago]
                                 [--clock wall|cpu]

Two trees of the same package cannot be imported in one process, so each round runs one short
subprocess per tree, in alternating order (A B, B A, A B, ...), with that tree first on
``PYTHONPATH``. Each subprocess times the bench trajectory's control cycle (``Controller.solve``
on the moving CoM and hand targets, ``benchmarks.harness`` of that tree, the same as
``same_behaviour.py``) for Talos and TIAGo with each solver, after a warm-up, and prints the
median cycle (ms): wall time (``perf_counter``) or, with ``--clock cpu``, the thread's CPU
time (``thread_time``: a cycle preempted by another process on a loaded machine is not
charged for the wait). The table gives, per case, the range of the medians over the rounds for
each tree and the range of the per-round ratios B/A: a change is "unchanged within noise" when
that range straddles 1.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

PROBE = r"""
import json, sys, time, warnings
import numpy as np, pinocchio as pin
import wbc
from benchmarks.harness import stacks, trajectory
warnings.simplefilter("ignore")
cycles, robots = int(sys.argv[1]), sys.argv[2].split(",")
clock = time.thread_time if sys.argv[3] == "cpu" else time.perf_counter
out = {}
for rname, make, circles in (("talos", stacks.talos_stack, ("right_hand", "left_hand")),
                             ("tiago", stacks.tiago_stack, ("hand",))):
    if rname not in robots:
        continue
    robot = wbc.load_robot(rname)
    for solver in ("hqp", "projection", "weighted"):
        stack = make()
        ctrl = wbc.Controller(robot, stack, solver=solver, backend="daqp")
        q, v = robot.q_default.copy(), np.zeros(robot.nv)
        robot.update(q, v)
        targets = trajectory.moving_targets(robot, stack, circles)
        times = []
        for k in range(cycles + 200):
            targets(k * trajectory.DT)
            t0 = clock()
            sol = ctrl.solve(q, v)
            if k >= 200:
                times.append(clock() - t0)
            v = v + sol.qdd * trajectory.DT
            q = pin.integrate(robot.model, q, v * trajectory.DT)
        out[f"{rname}/{solver}"] = float(np.median(times)) * 1e3
print(json.dumps(out))
"""


def probe(tree: str, cycles: int, robots: str = "talos,tiago", clock: str = "wall") -> dict:
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree))
    got = subprocess.run([sys.executable, "-c", PROBE, str(cycles), robots, clock], cwd=tree, env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(got.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--cycles", type=int, default=1500)
    ap.add_argument("--robots", default="talos,tiago", help="comma-separated: talos, tiago")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    args = ap.parse_args()
    probe(args.before, 50, args.robots), probe(args.after, 50, args.robots)   # compile both trees' kernels first
    res: dict[str, list] = {"A": [], "B": []}
    for r in range(args.rounds):
        order = ("A", "B") if r % 2 == 0 else ("B", "A")
        for which in order:
            res[which].append(probe(args.before if which == "A" else args.after, args.cycles, args.robots, args.clock))
    print(f"A = {args.before}, B = {args.after}; {args.rounds} rounds alternated, {args.cycles} cycles each; "
          f"median control cycle per round (ms, {args.clock} clock)")
    print("| case | A (ms) | B (ms) | B/A per round |\n| --- | --- | --- | --- |")
    for case in res["A"][0]:
        a = [x[case] for x in res["A"]]
        b = [x[case] for x in res["B"]]
        ratio = [y / x for x, y in zip(a, b)]
        print(f"| {case} | {min(a):.3f}-{max(a):.3f} | {min(b):.3f}-{max(b):.3f} | {min(ratio):.2f}-{max(ratio):.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
