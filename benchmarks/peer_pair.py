"""wbc hqp against PlaCo's DynamicsSolver, interleaved cycle by cycle in one process: the
bench's Talos stack and trajectory with the contacts' default 20 % CoP margin, the same with
the CoP allowed over the whole sole (as PlaCo's planar contacts allow it), and PlaCo on the
same trajectory (pinocchio 3.8 environment). Each cycle k runs the three one after the
other, so a burst of load on a shared machine hits all three alike; medians per round (of
``ctrl.solve`` and of PlaCo's ``solve``) and their ratios. ``ctrl.solve`` runs the cycle's
pinocchio algorithms itself (``RobotModel.update``); PlaCo runs part of its own in
``RobotWrapper.update_kinematics`` before ``solve``, so the last figure is the ratio to
PlaCo's ``update_kinematics`` + ``solve`` (the same work from a state to torques).

    PYTHONPATH=. python benchmarks/peer_pair.py [ROUNDS] [CYCLES]
"""

from __future__ import annotations

import functools
import sys
import warnings

import numpy as np

from benchmarks.harness import peers, stacks, timing
from wbc.robot.loader import load_robot

WARMUP = 200
HANDS = ("right_hand", "left_hand")


def main(rounds: int = 3, cycles: int = 2000) -> None:
    warnings.simplefilter("ignore")
    missing = peers._placo_available()
    if missing:
        sys.exit(missing)
    robot = load_robot("talos")
    whole_sole = functools.partial(stacks.talos_stack, cop_margin=0.0)
    for r in range(rounds):
        wbc = timing.CycleRun(robot, stacks.talos_stack, "hqp", "daqp", HANDS)
        wbc0 = timing.CycleRun(robot, whole_sole, "hqp", "daqp", HANDS)
        placo = peers.PlacoDynamicsRun(robot)
        t = np.empty((4, cycles))
        qps = np.zeros(2)
        for k in range(WARMUP + cycles):
            tw, sw = wbc.step(k)
            tw0, sw0 = wbc0.step(k)
            tp, tpu = placo.step(k)[:2]
            if k >= WARMUP:
                t[:, k - WARMUP] = tw, tw0, tp, tpu
                qps += sw.qp_count, sw0.qp_count
        wm, w0m, pm, pum = np.median(t, axis=1) * 1e3
        p99 = np.percentile(t, 99, axis=1) * 1e3
        print(f"round {r}: wbc hqp median {wm:.3f} ms (p99 {p99[0]:.3f}, {qps[0] / cycles:.2f} QPs/cycle), "
              f"whole sole {w0m:.3f} ms ({qps[1] / cycles:.2f}), PlaCo solve median {pm:.3f} ms (p99 {p99[2]:.3f}); "
              f"ratios {wm / pm:.2f} / {w0m / pm:.2f}; to PlaCo's update_kinematics + solve ({pum:.3f} ms) "
              f"{wm / pum:.2f} / {w0m / pum:.2f}", flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
