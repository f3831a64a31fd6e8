"""Same behaviour where a change moves the last bits (#26): every control cycle's input recorded on
one tree, then given to the other tree's controller, open loop, and the outputs compared cycle by cycle.

    PYTHONPATH=BASE python benchmarks/same_replay.py record RUN.npz [CASES] [SIMULATORS]
    PYTHONPATH=NEW  python benchmarks/same_replay.py replay RUN.npz NEW.npz
    python benchmarks/same_replay.py compare RUN.npz NEW.npz [TOLERANCE]

``same_behaviour.py`` compares closed loops, bit for bit. A change that moves one cycle's answer by one
unit in the last place (another factorisation of the same QP, another summation order) cannot pass
it on the scenarios that amplify rounding: talos_push, g1_push, talos_hands_cross and panda_obstacle
carry a 1e-13 perturbation of the state to N·m within a second (``benchmarks/optimisation.md``,
perf11-13 and perf27), whatever the change. This script takes the plant out of that loop: ``record``
runs each case on the base tree and stores, per cycle, what ``Controller.solve`` was given (q, v and
the external torque) and what it returned; ``replay`` runs the same cases on the new tree with each
cycle's ``Controller.solve`` given the recorded input instead of the live one, and each simulator step
given the recorded torque instead of the new one (the plant then follows the recording: a run that
the new torques, open loop, would end early by a fall runs whole), so that both trees' controllers
see the same states; ``compare`` prints per case the largest |Δ| over the cycles relative to that
cycle's largest |output| and fails (exit 1) above TOLERANCE (default 1e-9, the agreement
issue #26 asks of a change of factorisation).

Only the controller's own state (its warm starts, hint tables, force ramps) is carried from cycle to
cycle in a replay, so its differences are the change's, not the plant's. A velocity-mode case's
position servos are not driven from the recording (their plant runs on the new commands); anything the
loop takes from such a live plant would show as a difference, never hide one. The same tree replayed
against its own recording is identical (the check of this script). Outputs: τ (N·m) for the torque
cases, q̇ (rad/s, m/s) for the velocity ones.

CASES: comma-separated ``scenario`` or ``scenario/solver`` (default: the scenarios of
``same_behaviour.py record`` with each solver, and g1_push, talos_hands_cross, panda_obstacle and
tiago_table_reach_velocity with their own); SIMULATORS: ``pinocchio,mujoco`` (default ``pinocchio``;
the collision scenarios run on the own simulator only).
"""

from __future__ import annotations

import sys
import warnings

import numpy as np

#: the cases ``record`` runs by default: (scenario, solver or None for the scenario's own, seconds)
DEFAULT_CASES = tuple((s, solver, 1.6 if s == "talos_push" else 1.0)
                      for s in ("talos_balance", "talos_reach", "talos_push", "talos_step", "tiago_reach")
                      for solver in ("hqp", "projection", "weighted")) + (
    ("g1_push", None, 1.0), ("talos_hands_cross", None, 2.0), ("panda_obstacle", None, 2.0),
    ("tiago_table_reach_velocity", None, 2.0))
#: the scenarios with a collision model (the MuJoCo back-end is not asked of them here)
OWN_SIMULATOR_ONLY = ("talos_hands_cross", "panda_obstacle", "tiago_table_reach_velocity")


def _cases(spec: str | None) -> list[tuple[str, str | None, float]]:
    if not spec:
        return list(DEFAULT_CASES)
    seconds = {s: t for s, _, t in DEFAULT_CASES}
    out = []
    for item in spec.split(","):
        name, _, solver = item.partition("/")
        out.append((name, solver or None, seconds.get(name, 1.0)))
    return out


def _output(sol) -> np.ndarray:
    """What a cycle commands: τ of a torque solution, q̇ of a velocity one."""
    tau = getattr(sol, "tau", None)
    return (tau if tau is not None else sol.qd).copy()


def run_case(name: str, solver: str | None, seconds: float, sim: str, given: dict | None) -> dict:
    """One case; ``given``: the recorded inputs to substitute (None: record the live ones)."""
    from wbc.controller.cycle import Controller
    from wbc.controller.velocity import VelocityController
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    qs: list = []
    vs: list = []
    taus_e: list = []
    flags: list = []
    outs: list = []

    def replaying(solve):
        def replayed(self, q, v=None, external_torque=None):
            i = len(outs)
            if given is not None:
                if i >= len(given["q"]):
                    raise RuntimeError(f"{name}: the replay ran past the recording's {len(given['q'])} cycles")
                q, v = given["q"][i].copy(), given["v"][i].copy()
                external_torque = given["tau_e"][i].copy() if given["has_tau_e"][i] else None
            qs.append(np.array(q, dtype=float))
            vs.append(np.array(v, dtype=float))
            has = external_torque is not None
            flags.append(has)
            taus_e.append(np.array(external_torque, dtype=float) if has else np.zeros(len(v)))
            sol = solve(self, q, v, external_torque)
            outs.append(_output(sol))
            return sol
        return replayed

    sent: list = []

    def sending(step):
        def replayed_step(self, tau):
            i = len(sent)
            if given is not None and "sent" in given and i < len(given["sent"]):
                tau = given["sent"][i].copy()     # the recorded command: the plant follows the recording
            sent.append(np.array(tau, dtype=float))
            return step(self, tau)
        return replayed_step

    settings = {"duration": seconds, "simulator": sim}
    if solver is not None:
        settings["solver"] = solver
    solves = Controller.solve, VelocityController.solve
    plants = _simulator_classes()
    steps = [cls.step for cls in plants]
    Controller.solve = replaying(solves[0])           # type: ignore[method-assign]
    VelocityController.solve = replaying(solves[1])   # type: ignore[method-assign]
    for cls, step in zip(plants, steps, strict=True):
        cls.step = sending(step)
    try:
        run(load_config(name), **settings)
    finally:
        Controller.solve, VelocityController.solve = solves   # type: ignore[method-assign]
        for cls, step in zip(plants, steps, strict=True):
            cls.step = step
    return {"q": np.array(qs), "v": np.array(vs), "tau_e": np.array(taus_e), "has_tau_e": np.array(flags),
            "sent": np.array(sent),
            "out": np.array(outs)}


def _simulator_classes() -> list:
    """The simulators whose ``step(tau)`` a replay drives with the recorded torques."""
    from wbc.sim.simulator import Simulator

    try:
        from wbc.sim.mujoco_sim import MujocoSimulator
    except ImportError:                                  # (an environment without MuJoCo)
        return [Simulator]
    return [Simulator, MujocoSimulator]


def _keys(data) -> list[str]:
    return sorted({k.rsplit("/", 1)[0] for k in data.files if k.endswith("/out")})


def record(path: str, cases: list[tuple[str, str | None, float]], simulators: list[str]) -> None:
    warnings.simplefilter("ignore")
    out: dict = {}
    for name, solver, seconds in cases:
        for sim in simulators:
            if sim != "pinocchio" and name in OWN_SIMULATOR_ONLY:
                continue
            got = run_case(name, solver, seconds, sim, None)
            key = f"{name}/{sim}/{solver or 'default'}"
            out.update({f"{key}/{f}": a for f, a in got.items()})
            out[f"{key}/seconds"] = np.array([seconds])
            print(f"{key:44s} {len(got['out'])} cycles", flush=True)
    np.savez(path, **out)


def replay(recorded: str, path: str) -> None:
    warnings.simplefilter("ignore")
    data = np.load(recorded)
    out: dict = {}
    for key in _keys(data):
        name, sim, solver = key.split("/")
        given = {f: data[f"{key}/{f}"] for f in ("q", "v", "tau_e", "has_tau_e", "sent") if f"{key}/{f}" in data.files}
        got = run_case(name, None if solver == "default" else solver, float(data[f"{key}/seconds"][0]), sim, given)
        out[f"{key}/out"] = got["out"]
        print(f"{key:44s} {len(got['out'])} cycles replayed", flush=True)
    np.savez(path, **out)


def compare(recorded: str, replayed: str, tolerance: float = 1e-9) -> int:
    a, b = np.load(recorded), np.load(replayed)
    worst = 0.0
    failed = 0
    for key in _keys(a):
        x = a[f"{key}/out"]
        if f"{key}/out" not in b.files:
            print(f"{key:44s} missing in the replay")
            failed += 1
            continue
        y = b[f"{key}/out"]
        if x.shape != y.shape:
            print(f"{key:44s} {len(x)} cycles recorded, {len(y)} replayed")
            failed += 1
            continue
        if np.array_equal(x, y):
            print(f"{key:44s} identical")
            continue
        d = np.max(np.abs(x - y), axis=1)
        scale = np.maximum(np.max(np.abs(x), axis=1), 1e-300)
        rel = d / scale
        i = int(np.argmax(rel))
        worst = max(worst, float(rel[i]))
        equal = int(np.sum(d == 0.0))
        unit = "rad/s" if name_is_velocity(key) else "N·m"
        verdict = "ok" if rel[i] <= tolerance else "ABOVE TOLERANCE"
        print(f"{key:44s} max |Δ| {float(d.max()):.3g} {unit}, relative {float(rel[i]):.2g} at cycle {i} "
              f"({equal}/{len(d)} cycles bit for bit) {verdict}")
        failed += rel[i] > tolerance
    print(f"largest relative difference {worst:.3g} (tolerance {tolerance:g})")
    return 1 if failed else 0


def name_is_velocity(key: str) -> bool:
    """Whether a case's outputs are q̇ (a velocity-mode scenario) rather than τ."""
    return key.split("/")[0].endswith("_velocity")


if __name__ == "__main__":
    args = sys.argv[1:]
    if len(args) >= 2 and args[0] == "record":
        record(args[1], _cases(args[2] if len(args) > 2 else None),
               args[3].split(",") if len(args) > 3 else ["pinocchio"])
    elif len(args) == 3 and args[0] == "replay":
        replay(args[1], args[2])
    elif len(args) in (3, 4) and args[0] == "compare":
        sys.exit(compare(args[1], args[2], float(args[3]) if len(args) == 4 else 1e-9))
    else:
        sys.exit(__doc__)
