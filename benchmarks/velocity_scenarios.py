"""Velocity mode in closed loop, both simulators: tiago_table_reach_velocity (issue #23).

Per run: the smallest exact distance between any robot link and the table over every cycle
(coal, on the simulator's true state: all links, not only the broad phase's), the hand's error
before the target switch (reachable target) and at the end (unreachable one), which level the
last cycle reports sacrificed, relaxed cycles, joint-velocity violations, a fall.

    PYTHONPATH=. python benchmarks/velocity_scenarios.py [--sim pinocchio mujoco] > benchmarks/velocity_scenarios.md
"""

from __future__ import annotations

import argparse
import os
import subprocess

import numpy as np
import pinocchio as pin

from wbc.collision.model import CollisionModel
from wbc.runner.loop import run
from wbc.scenario.loader import load_config

SCENARIO = "tiago_table_reach_velocity"
SWITCH = 5.0


def one(sim: str) -> dict:
    sc = load_config(SCENARIO)
    task = sc.stack["collision_avoidance"]
    table = CollisionModel(sc.robot, obstacles=task.obstacles, self_collision=False)
    hand = sc.robot.frame_id("hand")
    out = {"d_min": np.inf, "pair": "", "before": np.nan, "final": np.nan, "sacrificed": []}
    targets = {"hand": np.array([0.82, -0.2, 0.56]), "hand_into_table": np.array([1.0, -0.2, 0.68])}
    data = sc.robot.model.createData()

    def watch(t, s, sol):
        d = table.all_distances(s.q, data)
        k = int(np.argmin(d))
        if d[k] < out["d_min"]:
            out["d_min"], out["pair"] = float(d[k]), table.pair_name(k)
        pin.updateFramePlacement(sc.robot.model, data, hand)
        p = data.oMf[hand].translation
        if abs(t + sc.dt - SWITCH) < 0.5 * sc.dt:
            out["before"] = float(np.linalg.norm(p - targets["hand"]))
        out["final"] = float(np.linalg.norm(p - targets["hand_into_table"]))
        out["sacrificed"] = [d_.sacrificed for d_ in sol.diagnostics]

    m = run(sc, simulator=sim, callback=watch)
    return {**out, "metrics": m}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sim", nargs="+", default=["pinocchio", "mujoco"])
    args = ap.parse_args()
    sha = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print(f"# Velocity mode, closed loop: {SCENARIO}\n\ncommit {sha}; `{' '.join(['python', *os.sys.argv])}`; "
          f"load {os.getloadavg()[0]:.2f}\n")
    print("| simulator | min link–table distance (m) | closest | hand error at 5 s (m) "
          "| hand error final, target in table (m) "
          "| sacrificed (last cycle) | relaxed cycles | joint-velocity violations | fell |")
    print("|---|---|---|---|---|---|---|---|---|")
    for sim in args.sim:
        r = one(sim)
        m = r["metrics"]
        at5, fin = r["before"], r["final"]
        print(f"| {m['simulator']} | {r['d_min']:.4f} | {r['pair']} | {at5:.4f} | {fin:.4f} | {r['sacrificed']} | "
              f"{m['relaxed_cycles']} | {m['violations']['joint_velocity']} | {m['fell']} |")


if __name__ == "__main__":
    main()
