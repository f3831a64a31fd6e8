"""Same behaviour before and after a change: closed-loop torques recorded and compared.

    python benchmarks/same_behaviour.py record OUT.npz [pinocchio,mujoco]
    python benchmarks/same_behaviour.py record-velocity OUT.npz [pinocchio,mujoco]
    python benchmarks/same_behaviour.py record-collision OUT.npz [SECONDS]
    python benchmarks/same_behaviour.py compare BEFORE.npz AFTER.npz

``record`` runs, on the tree it is run from (PYTHONPATH), the bench trajectory (1,500 cycles
of the moving CoM and hand targets, Talos and TIAGo) and five scenarios (talos_balance,
talos_reach, talos_push, talos_step, tiago_reach; 1.0 s, talos_push 1.6 s to include the
push) in each simulator, with each solver, and stores every cycle's τ. ``compare`` prints,
per case, ``identical`` (bit for bit) or the largest |Δτ| and its relative size.
``record-velocity`` does the same for the velocity mode: every cycle's q̇ of
tiago_table_reach_velocity (the whole 9 s, each simulator) and of the Talos IK problem of
``ik_peers.py`` (its Gauss–Newton iterations from q0, each solver); compared the same way
(the Δ then in rad/s and m/s).
``record-collision`` runs the collision scenarios on the own simulator for SECONDS (default 2):
talos_hands_cross (its default exact drift, and with ``drift: analytic``), tiago_table_reach,
panda_obstacle and tiago_table_reach_velocity; it stores every cycle's τ (q̇ for the velocity one) and the run's
``collision_distance_min`` (m, as a 1-vector ``…/collision_distance_min``). It can be run on an older tree
by giving this file's path with that tree on PYTHONPATH.
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


def record_velocity(path: str, simulators: list[str]) -> None:
    import pinocchio as pin

    from benchmarks.ik_peers import Problem, WbcIK
    from wbc.robot.loader import load_robot
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    warnings.simplefilter("ignore")
    out = {}
    for sim in simulators:
        qds: list = []
        run(load_config("tiago_table_reach_velocity"), simulator=sim,
            callback=lambda t, s, sol, qds=qds: qds.append(sol.qd.copy()))
        out[f"tiago_table_reach_velocity/{sim}"] = np.array(qds)
    pb = Problem(load_robot("talos"))
    for solver in ("hqp", "projection", "weighted"):
        ik = WbcIK(pb)
        if solver != "hqp":
            from wbc import Controller
            ik.ctrl = Controller(pb.robot, ik.ctrl.stack, mode="velocity", solver=solver, dt=ik.ctrl.dt,
                                 gain=ik.ctrl.gain)
        q, qds = pb.q0.copy(), []
        for _ in range(30):
            dq = ik.solve(q)
            qds.append(dq.copy())
            q = pin.integrate(pb.model, q, dq)
        out[f"talos_ik/{solver}"] = np.array(qds)
    np.savez(path, **out)


def record_collision(path: str, seconds: float) -> None:
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    warnings.simplefilter("ignore")
    out = {}
    for name, drift in (("talos_hands_cross", None), ("talos_hands_cross", "analytic"), ("tiago_table_reach", None),
                        ("panda_obstacle", None), ("tiago_table_reach_velocity", None)):
        sc = load_config(name)
        if drift is not None:
            task = sc.stack["collision_avoidance"]
            task.drift = drift
            if task.model is not None:
                task.model.analytic_drift = drift == "analytic"
        got: list = []
        velocity = name.endswith("_velocity")
        metrics = run(sc, simulator="pinocchio", duration=seconds,
                      callback=lambda t, s, sol, got=got, velocity=velocity: got.append(
                          (sol.qd if velocity else sol.tau).copy()))
        key = f"{name}{'/' + drift if drift else ''}"
        out[key] = np.array(got)
        out[f"{key}/collision_distance_min"] = np.array([metrics["collision_distance_min"]])
        print(f"{key:40s} collision_distance_min {metrics['collision_distance_min']!r} m", flush=True)
    np.savez(path, **out)


#: the cases record_velocity writes (q̇ commands, rad/s; the others are torques, N·m)
VELOCITY_CASES = ("tiago_table_reach_velocity", "talos_ik")


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
            what = "|Δq̇| {:.3g} rad/s" if key.split("/")[0] in VELOCITY_CASES else "|Δτ| {:.3g} N·m"
            print(f"{key:36s} max {what.format(d)} (relative {d / max(float(np.max(np.abs(x))), 1e-300):.2g})")
            differ += 1
    return 1 if differ else 0


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "record":
        record(sys.argv[2], sys.argv[3].split(",") if len(sys.argv) > 3 else ["pinocchio", "mujoco"])
    elif len(sys.argv) >= 3 and sys.argv[1] == "record-velocity":
        record_velocity(sys.argv[2], sys.argv[3].split(",") if len(sys.argv) > 3 else ["pinocchio", "mujoco"])
    elif len(sys.argv) >= 3 and sys.argv[1] == "record-collision":
        record_collision(sys.argv[2], float(sys.argv[3]) if len(sys.argv) > 3 else 2.0)
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(__doc__)
