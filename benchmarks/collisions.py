"""Cost of self-collision avoidance on Talos: interleaved A/B in one process.

    PYTHONPATH=. python benchmarks/collisions.py [--seconds 6.0] [--rounds 5] [--out benchmarks/collisions.json]

1. Runs ``talos_hands_cross`` (every self pair of the pair file monitored, the arms crossing)
   on the own simulator for ``--seconds`` and keeps the measured states (q, v) and the hand
   references of every 10th cycle.
2. On those states, times the control cycle (``Controller.solve``) of the scenario's stack (A:
   with the collision task) and of the same stack without it (B), alternately state by state
   (A B, B A, ...), ``--rounds`` passes; per round the median of each, and the ratio A/B.
3. The distance phase alone (``CollisionModel.distance_rows``: broad phase, coal on the near
   pairs, rows d, J_d, J̇_d q̇) on the same states, with the drift from the exact second
   difference (the default) and from the witness points' rigid motion only, how many pairs
   are within the influence distance (rows) and how many the broad phase passed to coal.

``--drift analytic`` times the cycle (A) with the collision task's analytic drift (``drift: analytic``,
:mod:`wbc.collision.feature_drift`: no coal pass for J̇_d q̇), ``--drift switching`` with the scenario's own
(``drift: switching``: the exact passes and the switches' jumps), ``exact`` (the default) with the exact second
difference alone; the distance phase is timed with each drift (exact, analytic, rigid witness-point, switching)
whatever the flag. ``--every 1`` replays every cycle, as
the control loop calls it (the broad phase's bound grows with the step between calls, so states 10
cycles apart pass ~3× more pairs to coal than the 1 ms loop does).

``--geometry primitives`` runs it all with the collision task on the robot's primitives
(``geometry: primitives``: the capsules and boxes of ``talos.collisions.yaml``); with
``--max-excess X`` (m) they are first refitted into a scratch copy of that file, every geometry
whose primitive over-approximates its hull by at most X getting one (1.0: all of them).

Each call is timed twice: wall clock (``perf_counter``) and this thread's CPU time
(``thread_time``). On a shared machine under load the wall-clock medians measure the scheduler
(a call longer than a few ms straddles a preemption: at load 8-14 on 2 cores, A's median went
from 2.2 ms CPU to 9.2 ms wall while B's, shorter, stayed at 0.65-0.7 ms), so the CPU-time
figures (``*_cpu_ms``) are the comparable ones.

Reports ranges over the rounds with ``uptime``'s load (the machine is shared): numbers for
benchmarks/collisions.md, not asserted anywhere.
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings

import numpy as np

from wbc.controller.cycle import Controller
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config
from wbc.stack import Stack


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _use_primitives(sc, max_excess: float | None) -> None:
    """The scenario's collision task on the robot's primitives (refitted into a scratch copy of the collision file
    when ``max_excess`` is given)."""
    import shutil
    import tempfile
    from pathlib import Path

    from wbc.collision.model import CollisionModel
    from wbc.collision.pairs import pair_file, write_primitives
    from wbc.collision.primitives import fit_primitives

    robot = sc.robot
    if max_excess is not None:
        tmp = Path(tempfile.mkdtemp(prefix="wbc_prims_"))
        shutil.copy(pair_file(robot), tmp / pair_file(robot).name)
        robot.source = tmp / robot.source.name
        kept, _ = fit_primitives(CollisionModel(robot, self_collision=False), max_excess)
        write_primitives(robot, kept, {"max_excess": max_excess})
    task = sc.stack["collision_avoidance"]
    task.geometry = "primitives"
    task.model = None
    task.bind(robot)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("--out", default=None)
    ap.add_argument("--geometry", choices=["hulls", "primitives"], default="hulls")
    ap.add_argument("--max-excess", type=float, default=None)
    ap.add_argument("--drift", choices=["exact", "analytic", "switching"], default="exact")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    sc = load_config("talos_hands_cross")
    if a.geometry == "primitives":
        _use_primitives(sc, a.max_excess)
    task = sc.stack["collision_avoidance"]
    task.drift = a.drift
    if task.model is not None:                  # the loader bound the model with the scenario's drift
        task.model.analytic_drift = a.drift == "analytic"
        task.model.switch_jump = a.drift == "switching"
    r = ScenarioRun(sc, duration=a.seconds)
    hands = [t for t in sc.stack if t.kind == "frame" and t.moves_position]
    states = []
    for k in range(r.n):
        q, v = r.sim.q.copy(), r.sim.v.copy()
        if not r.cycle(k):
            break
        if k % a.every == 0:
            states.append((q, v, [(t.name, t.target.copy(), t.target_velocity.copy(), t.target_acceleration.copy())
                                  for t in hands]))
    metrics = r.metrics()
    coll = sc.stack["collision_avoidance"]
    levels_b = [[t for t in lvl if t.kind != "collision_avoidance"] for lvl in sc.stack.levels]
    robot = sc.robot
    stack_a = sc.stack
    stack_b = Stack([lvl for lvl in levels_b if lvl])
    ctrl_a = Controller(robot, stack_a, solver="hqp", dt=sc.dt)
    ctrl_b = Controller(robot, stack_b, solver="hqp", dt=sc.dt)

    def solve(ctrl, stack, state):
        q, v, refs = state
        for name, M, vel, acc in refs:
            stack[name].set_reference(M, vel, acc)
        t0, c0 = time.perf_counter(), time.thread_time()
        ctrl.solve(q, v)
        return time.perf_counter() - t0, time.thread_time() - c0

    for s in states[:20]:                       # warm-up (kernels, caches)
        solve(ctrl_a, stack_a, s)
        solve(ctrl_b, stack_b, s)
    rounds = []
    for rnd in range(a.rounds):
        ta, tb = [], []
        for i, s in enumerate(states):
            if (i + rnd) % 2:
                ta.append(solve(ctrl_a, stack_a, s))
                tb.append(solve(ctrl_b, stack_b, s))
            else:
                tb.append(solve(ctrl_b, stack_b, s))
                ta.append(solve(ctrl_a, stack_a, s))
        (ma, ca), (mb, cb) = np.median(ta, axis=0), np.median(tb, axis=0)
        rounds.append({"with_ms": ma * 1e3, "without_ms": mb * 1e3, "ratio": ma / mb,
                       "with_cpu_ms": ca * 1e3, "without_cpu_ms": cb * 1e3, "ratio_cpu": ca / cb, "load": _load()})
    model = coll.model
    phase = {}
    near: list[int] = []
    computed: list[int] = []
    for kind in ("exact", "analytic", "witness", "switching"):
        exact = kind != "witness"
        model.exact_drift = exact
        model.analytic_drift = kind == "analytic"
        model.switch_jump = kind == "switching"
        times = []
        for _ in range(a.rounds):
            for q, v, _ in states:
                robot.update(q, v)
                t0, c0 = time.perf_counter(), time.thread_time()
                rows = model.distance_rows(robot, coll.influence)
                times.append((time.perf_counter() - t0, time.thread_time() - c0))
                if kind == "exact":
                    near.append(len(rows.d))
                    computed.append(getattr(model, "computed", -1))
        phase[f"{kind}_drift"] = {
            "median_ms": float(np.median(times, axis=0)[0]) * 1e3, "p90_ms": float(np.percentile(times, 90, axis=0)[0]) * 1e3,
            "median_cpu_ms": float(np.median(times, axis=0)[1]) * 1e3,
            "p90_cpu_ms": float(np.percentile(times, 90, axis=0)[1]) * 1e3}
    model.exact_drift = True
    model.analytic_drift = a.drift == "analytic"
    model.switch_jump = a.drift == "switching"
    out = {"geometry": a.geometry, "drift": a.drift, "every": a.every, "max_excess": a.max_excess,
           "primitives": len(getattr(model, "primitive_names", [])),
           "states": len(states), "pairs": len(model.pairs), "geometries": model.geometry_model.ngeoms,
           "near_pairs": {"median": float(np.median(near)), "max": int(max(near))},
           "computed_pairs": {"median": float(np.median(computed)), "max": int(max(computed))},
           "collision_distance_min": metrics.get("collision_distance_min"),
           "collision_closest_pair": metrics.get("collision_closest_pair"),
           "cycle": rounds, "distance_phase": phase, "load_end": _load()}
    print(json.dumps(out, indent=1))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
