"""Same behaviour before and after a change: closed-loop torques recorded and compared.

    python benchmarks/same_behaviour.py record OUT.npz [pinocchio,mujoco]
    python benchmarks/same_behaviour.py compare BEFORE.npz AFTER.npz

``record`` runs, on the tree it is run from (PYTHONPATH), the bench trajectory (1,500 cycles
of the moving CoM and hand targets, Talos and TIAGo) and five scenarios (talos_balance,
talos_reach, talos_push, talos_step, tiago_reach; 1.0 s, talos_push 1.6 s to include the
push) in each simulator, with each solver, and stores every cycle's τ. ``compare`` prints,
per case, ``identical`` (bit for bit) or the largest |Δτ| and its relative size.
"""

from __future__ import annotations

import sys
import warnings

import numpy as np


def record(path: str, simulators: list[str]) -> None:
    import pinocchio as pin

    from benchmarks.harness import stacks, trajectory
    from wbc.controller.cycle import Controller
    from wbc.robot.loader import load_robot
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    warnings.simplefilter("ignore")
    out = {}
    for rname, make, circles in (("talos", stacks.talos_stack, ("right_hand", "left_hand")),
                                 ("tiago", stacks.tiago_stack, ("hand",))):
        robot = load_robot(rname)
        for solver in ("hqp", "projection", "weighted"):
            stack = make()
            ctrl = Controller(robot, stack, solver=solver, backend="daqp")
            q, v = robot.q_default.copy(), np.zeros(robot.nv)
            robot.update(q, v)
            targets = trajectory.moving_targets(robot, stack, circles)
            taus = []
            for k in range(1500):
                targets(k * trajectory.DT)
                sol = ctrl.solve(q, v)
                taus.append(sol.tau.copy())
                v = v + sol.qdd * trajectory.DT
                q = pin.integrate(robot.model, q, v * trajectory.DT)
            out[f"bench/{rname}/{solver}"] = np.array(taus)
    for scenario in ("talos_balance", "talos_reach", "talos_push", "talos_step", "tiago_reach"):
        for sim in simulators:
            for solver in ("hqp", "projection", "weighted"):
                taus: list = []
                run(load_config(scenario), solver=solver, simulator=sim, duration=1.6 if scenario == "talos_push" else 1.0,
                    callback=lambda t, s, sol, taus=taus: taus.append(sol.tau.copy()))
                out[f"{scenario}/{sim}/{solver}"] = np.array(taus)
    np.savez(path, **out)


def compare(before: str, after: str) -> int:
    a, b = np.load(before), np.load(after)
    differ = 0
    for key in a.files:
        if key not in b.files:
            print(f"{key:36s} missing after")
            differ += 1
            continue
        x, y = a[key], b[key]
        if x.shape != y.shape:
            print(f"{key:36s} shapes {x.shape} and {y.shape}")
            differ += 1
        elif np.array_equal(x, y):
            print(f"{key:36s} identical")
        else:
            d = float(np.max(np.abs(x - y)))
            print(f"{key:36s} max |Δτ| {d:.3g} N·m (relative {d / max(float(np.max(np.abs(x))), 1e-300):.2g})")
            differ += 1
    return 1 if differ else 0


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "record":
        record(sys.argv[2], sys.argv[3].split(",") if len(sys.argv) > 3 else ["pinocchio", "mujoco"])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(__doc__)
