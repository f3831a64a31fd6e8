"""Benchmark harness: cycle time of the controller, where it goes, and what it could be.

    wbc bench [--quick] [--json FILE] [--out-dir DIR] [--cycles N] [--backends daqp,proxqp,...]

Measures only; nothing here changes how the controller solves.

- **Cases**: Talos, full stack (5 levels: limits + two foot contacts / CoM / both hands /
  posture / contact-force regularisation, each sole's wrench towards half the weight) and TIAGo
  (limits / hand position / posture, differential drive), each with the ``projection``, ``hqp``
  and ``weighted`` solvers, the QP solvers with every back-end. ``cycles`` cycles after a
  warm-up, along a moving trajectory: the targets change every cycle (CoM sinusoid, hand
  targets on small circles) and the state moves (the returned q̈ integrated as a double
  integrator, dt = 1 ms). Per case: median, p99 and max cycle time, and the split by phase
  (model update, task rows, solve, torques and diagnostics), measured by wrapping the controller's own methods with timers.
- **Floor**: what one Talos cycle cannot go below in this process: the pinocchio calls
  :meth:`RobotModel.update <wbc.model.RobotModel.update>` makes plus the Jacobians, velocities
  and drifts the tasks extract, and one daqp solve of a same-size QP (the whole stack as a
  single weighted QP, level 0 as constraints: 50 variables, 18 equality and 100 inequality
  rows).
- **Peer**: PlaCo's ``DynamicsSolver`` on Talos with comparable tasks, and PlaCo's
  ``KinematicsSolver`` on the IK problem of ``wbc/placo_peer.py``.
- **Scaling**: cycle time against nv (serial chains built with pinocchio, nv 12 to 156)
  and against the number of levels (Talos, the same tasks split over 1 to 10 levels), with
  the log-log exponents, plotted to ``<out-dir>/scaling.png``.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import platform
import sys
import time
import warnings
from collections import Counter
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import numpy as np
import pinocchio as pin

from .controller import Controller
from .jsonable import plain
from .model import LOCAL, WORLD_ALIGNED, RobotModel, whole_body_terms
from .stack import Stack
from .tasks import CoM, Contact, ContactWrench, Frame, JointLimits, Posture, TorqueLimits
from .tasks.dynamics import FloatingBaseDynamics

BACKENDS = ("daqp", "proxqp", "quadprog", "osqp")
SOLVERS = ("projection", "hqp", "weighted")
PHASES = ("update", "rows", "solve", "finish")
DT = 1e-3
WARMUP = 200
QUICK_CYCLES, QUICK_WARMUP = 100, 20
FULL_BUDGET, QUICK_BUDGET = 180.0, 2.5     # s of wall time per case (see run_case)
CHAIN_NV = (12, 18, 24, 36, 48, 72, 96, 120, 156)
QUICK_CHAIN_NV = (12, 36, 96, 156)
LEVELS = tuple(range(1, 11))
QUICK_LEVELS = (1, 2, 4, 7, 10)

#: Talos's weight (N) as loaded by robots/talos.yaml (mass 90.27 kg × 9.81 m/s²), for the
#: contact-force regularisation of the full stack
TALOS_WEIGHT = 885.5

# reference motion: CoM sways sideways, hand targets go round small vertical circles
COM_AMPLITUDE, COM_FREQUENCY = 0.03, 0.5     # m, Hz
HAND_RADIUS, HAND_FREQUENCY = 0.03, 1.0      # m, Hz


# ------------------------------------------------------------------ stacks
def talos_stack() -> Stack:
    """The full Talos stack of the performance issue, 5 levels: hard constraints (joint and
    torque limits, two foot contacts) / CoM / both hands / posture / regularisation of the
    contact forces (each sole's wrench towards half the weight, the 6 internal-force
    directions nothing above decides).

    (An earlier version had a torso-orientation level in place of the regularisation: on this
    trajectory it left a pelvis-yaw mode to drift until joints ran at their velocity limits,
    which is neither what the issue specifies nor a motion a robot would make.)"""
    half = [0.0, 0.0, 0.5 * TALOS_WEIGHT, 0.0, 0.0, 0.0]
    return Stack([
        [JointLimits(), TorqueLimits(), Contact("left_foot"), Contact("right_foot")],
        [CoM(kp=100.0)],
        [Frame("right_hand", kp=50.0), Frame("left_hand", kp=50.0)],
        [Posture(kp=10.0)],
        [ContactWrench("left_foot_contact", target=half), ContactWrench("right_foot_contact", target=half)],
    ])


def tiago_stack() -> Stack:
    """TIAGo: limits / hand position / posture (the differential drive is added by the controller)."""
    return Stack([
        [JointLimits(), TorqueLimits()],
        [Frame("hand", kp=50.0, mask="position")],
        [Posture(kp=10.0)],
    ])


def talos_task_groups() -> list[list]:
    """Ten groups of Talos tasks, in priority order, for the levels sweep."""
    return [
        [JointLimits(), TorqueLimits(), Contact("left_foot"), Contact("right_foot")],
        [CoM(kp=100.0)],
        [Frame("right_hand", kp=50.0)],
        [Frame("left_hand", kp=50.0)],
        [Frame("torso", kp=20.0, mask="orientation")],
        [Frame("head", kp=20.0, mask="orientation")],
        [Frame("right_elbow", kp=20.0, mask="position")],
        [Frame("left_elbow", kp=20.0, mask="position")],
        [Frame("base", kp=20.0, mask="orientation")],
        [Posture(kp=10.0)],
    ]


def talos_levels_stack(n_levels: int) -> Stack:
    """The same ten task groups merged into ``n_levels`` consecutive levels (1 to 10)."""
    groups = talos_task_groups()
    chunks = np.array_split(np.arange(len(groups)), n_levels)
    return Stack([[t for g in chunk for t in groups[g]] for chunk in chunks])


def chain_stack() -> Stack:
    """The simple stack of the nv sweep: joint limits / tip / middle link / posture."""
    return Stack([
        [JointLimits()],
        [Frame("tip", kp=50.0, mask="position")],
        [Frame("mid", kp=50.0, mask="position")],
        [Posture(kp=10.0)],
    ])


def chain_robot(n: int, length: float = 1.0, mass: float = 10.0) -> RobotModel:
    """A fixed-base serial chain of ``n`` revolute joints (axes y, x, z in turn), built with
    pinocchio, ``length`` m and ``mass`` kg in all; frames ``tip`` (end) and ``mid``."""
    m = pin.Model()
    m.name = f"chain{n}"
    seg, mi = length / n, mass / n
    axes = (pin.JointModelRY, pin.JointModelRX, pin.JointModelRZ)
    parent = 0
    for i in range(n):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, seg if i else 0.0]))
        parent = m.addJoint(parent, axes[i % 3](), placement, f"joint_{i}", np.array([200.0]),
                            np.array([5.0]), np.array([-2.5]), np.array([2.5]))
        inertia = pin.Inertia(mi, np.array([0.0, 0.0, seg / 2]),
                              np.diag([mi * seg**2 / 12 + 1e-6, mi * seg**2 / 12 + 1e-6, 1e-6]))
        m.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    m.addFrame(pin.Frame("tip", parent, pin.SE3(np.eye(3), np.array([0.0, 0.0, seg])), pin.FrameType.OP_FRAME))
    m.addFrame(pin.Frame("mid", max(1, n // 2), pin.SE3(np.eye(3), np.array([0.0, 0.0, seg])),
                         pin.FrameType.OP_FRAME))
    q0 = np.random.default_rng(n).uniform(-0.3, 0.3, n)
    return RobotModel(name=f"chain{n}", model=m, root="fixed", actuated_root=False,
                      frames={"tip": "tip", "mid": "mid"}, contacts={}, q_default=q0,
                      q_min=m.lowerPositionLimit.copy(), q_max=m.upperPositionLimit.copy(),
                      v_max=m.velocityLimit.copy(), tau_max=m.effortLimit.copy())


# ------------------------------------------------------------- trajectory
ONSET = 0.2   # s: the motion starts from rest, its speed ramping up smoothly over this time


def _phase(t: float, w: float) -> tuple[float, float, float]:
    """Phase θ(t), θ̇, θ̈ of a motion whose angular speed ramps from 0 to ``w`` over
    :data:`ONSET` (θ̇ = w·smoothstep(t/ONSET)); then θ = w (t − ONSET/2)."""
    if t >= ONSET:
        return w * (t - ONSET / 2), w, 0.0
    x = max(t, 0.0) / ONSET
    return w * ONSET * (x**3 - x**4 / 2), w * (3 * x * x - 2 * x**3), w * (6 * x - 6 * x * x) / ONSET


def _circle(t: float, radius: float, freq: float, phase: float):
    """Offset, velocity, acceleration of a vertical circle in the y-z plane, 0 at t = 0
    (the target starts at rest, see :func:`_phase`)."""
    th, dth, ddth = _phase(t, 2 * np.pi * freq)
    a = th + phase
    s, c = np.sin(a), np.cos(a)
    p = radius * np.array([0.0, s - np.sin(phase), np.cos(phase) - c])
    tang = np.array([0.0, c, s])
    v = radius * dth * tang
    acc = radius * ddth * tang + radius * dth * dth * np.array([0.0, -s, c])
    return p, v, acc


def _sway(t: float):
    """Sideways CoM offset, velocity, acceleration (starting at rest, see :func:`_phase`)."""
    th, dth, ddth = _phase(t, 2 * np.pi * COM_FREQUENCY)
    s, c = np.sin(th), np.cos(th)
    A = COM_AMPLITUDE
    return (np.array([0.0, A * s, 0.0]), np.array([0.0, A * c * dth, 0.0]),
            np.array([0.0, A * (c * ddth - s * dth * dth), 0.0]))


def moving_targets(robot: RobotModel, stack: Stack, circles: tuple[str, ...] = ("right_hand", "left_hand"),
                   radius: float = HAND_RADIUS) -> Callable[[float], None]:
    """A function ``set(t)`` that moves the stack's targets (robot.update done at the start
    state): the CoM task sways sideways, the Frame tasks named in ``circles`` go round small
    circles; position, velocity and acceleration references are consistent, and the motion
    starts from rest (speed ramped up over :data:`ONSET`)."""
    com = next((t for t in stack if isinstance(t, CoM)), None)
    com0 = robot.com.copy() if com is not None else None
    frames = []
    for i, name in enumerate(n for n in circles if n in stack):
        task = stack[name]
        frames.append((task, robot.frame_placement(robot.frame_id(task.frame)).copy(), i * np.pi))
    zero3 = np.zeros(3)

    def set_targets(t: float) -> None:
        if com is not None:
            p, v, a = _sway(t)
            com.set_reference(com0 + p, v, a)
        for task, M0, phase in frames:
            p, v, a = _circle(t, radius, HAND_FREQUENCY, phase)
            task.set_reference(pin.SE3(M0.rotation, M0.translation + p), np.concatenate([v, zero3]),
                               np.concatenate([a, zero3]))

    return set_targets


# ----------------------------------------------------------- phase timing
class PhaseTimer:
    """Times the controller's phases by wrapping its own methods (instance attributes that
    shadow the class methods; removed by :meth:`restore`). Nested calls (a solver calling
    itself) count once."""

    def __init__(self) -> None:
        self.acc = dict.fromkeys(PHASES, 0.0)
        self._depth = 0
        self._wrapped: list[tuple[object, str]] = []

    def _wrap(self, obj, attr: str, phase: str) -> None:
        fn = getattr(obj, attr)
        clock = time.perf_counter
        acc = self.acc

        def timed(*args, **kwargs):
            if self._depth:
                return fn(*args, **kwargs)
            self._depth += 1
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                acc[phase] += clock() - t0
                self._depth -= 1

        setattr(obj, attr, timed)
        self._wrapped.append((obj, attr))

    def instrument(self, ctrl: Controller) -> None:
        self._wrap(ctrl.robot, "update", "update")
        self._wrap(ctrl.stack, "layout", "rows")
        self._wrap(ctrl.stack, "assemble", "rows")
        for attr in ("solve_levels", "solve_accelerations", "distribute_forces"):
            if hasattr(ctrl.solver, attr):
                self._wrap(ctrl.solver, attr, "solve")
        self._wrap(ctrl, "_finish", "finish")

    def reset(self) -> None:
        for k in self.acc:
            self.acc[k] = 0.0

    def restore(self) -> None:
        for obj, attr in reversed(self._wrapped):
            if attr in vars(obj):
                delattr(obj, attr)
        self._wrapped.clear()


# -------------------------------------------------------------- one case
def _stats(total: np.ndarray) -> dict:
    ms = total * 1e3
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max()), "mean_ms": float(ms.mean())}


def run_case(robot: RobotModel, make_stack: Callable[[], Stack], solver: str, backend: str | None,
             cycles: int, warmup: int, circles: tuple[str, ...] = ("right_hand", "left_hand"),
             phases: bool = True, label: str | None = None, budget_s: float | None = None) -> dict:
    """``warmup`` + ``cycles`` control cycles along the moving trajectory from the robot's
    default posture at rest; timing of the last ``cycles``. Only ``ctrl.solve`` is timed
    (setting the targets and integrating the state are not).

    Two passes over the same trajectory: the cycle times (median, p99, max) come from a
    pass with nothing but the controller; with ``phases``, a second pass wraps the
    phases with timers and reads ``sol.diagnostics`` after each cycle (timed apart). The
    timers cost a few µs per cycle, and working out the diagnostics between cycles
    leaves the next one with cold caches, so neither is in the first pass.

    ``budget_s``: wall-time budget of each pass; when it is used up the pass stops after
    the current cycle and the case is marked ``truncated`` (statistics over the cycles
    done), or reported as an error if not a single timed cycle was done."""
    first = _timed_pass(robot, make_stack, solver, backend, cycles, warmup, circles, False, budget_s)
    out = {"robot": label or robot.name, "solver": solver, "backend": backend if solver != "projection" else None,
           "levels": first["levels"], "nv": robot.nv, "nx": first["nx"], "cycles": first["done"], "warmup": warmup,
           "warmup_max_ms": float(first["warm"].max() * 1e3) if warmup else 0.0,
           "warmup_s": float(first["warm"].sum())}
    done = first["done"]
    if done < cycles:
        out["truncated"] = f"wall-time budget of {budget_s:g} s used up after {done} of {cycles} timed cycles"
        if done == 0:
            warm = first["warm"]
            out["error"] = (f"budget of {budget_s:g} s used up during the warm-up ({int(np.count_nonzero(warm))} "
                            f"of {warmup} cycles, slowest {warm.max() * 1e3:.0f} ms)")
            return out
    out.update(_stats(first["total"][:done]))
    if phases:
        second = _timed_pass(robot, make_stack, solver, backend, cycles, warmup, circles, True, budget_s)
        n = second["done"]
        total = second["total"][:n]
        per_phase = {p: a[:n] for p, a in second["phases"].items()}
        # reading sol.diagnostics (per-level residuals, active sets, σ_min of J̄_k) costs this
        # on top of the cycle; the controller computes them only when they are read
        out["diagnostics_ms"] = float(np.median(second["diag"][:n]) * 1e3)
        med = {p: float(np.median(per_phase[p]) * 1e3) for p in PHASES}
        mean = {p: float(per_phase[p].mean() * 1e3) for p in PHASES}
        other = total - sum(per_phase[p] for p in PHASES)
        med["other"] = float(np.median(other) * 1e3)
        mean["other"] = float(other.mean() * 1e3)
        out["phases"] = med
        out["phases_mean"] = mean
        # fraction of the instrumented pass's mean cycle that the four timed phases account for
        out["phase_coverage"] = float(sum(mean[p] for p in PHASES) / (total.mean() * 1e3))
        out["instrumented_median_ms"] = float(np.median(total) * 1e3)
        out["instrumented_mean_ms"] = float(total.mean() * 1e3)
    out["qp_per_cycle"] = first["qp_count"] / done
    out["statuses"] = dict(first["statuses"])
    if first["warns"]:
        out["warnings"] = dict(first["warns"].most_common(5))
    out["final_state_finite"] = first["finite"]
    return out


def _timed_pass(robot: RobotModel, make_stack: Callable[[], Stack], solver: str, backend: str | None,
                cycles: int, warmup: int, circles: tuple[str, ...], instrumented: bool,
                budget_s: float | None) -> dict:
    """One pass of :func:`run_case` from the default posture at rest."""
    stack = make_stack()
    ctrl = Controller(robot, stack, solver=solver, backend=backend or "daqp")
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    set_targets = moving_targets(robot, stack, circles)
    timer = PhaseTimer()
    if instrumented:
        timer.instrument(ctrl)
    total = np.empty(cycles)
    diag = np.empty(cycles)
    per_phase = {p: np.empty(cycles) for p in PHASES}
    statuses: Counter = Counter()
    warns: Counter = Counter()
    qp_count = 0
    model, clock = robot.model, time.perf_counter
    warm = np.zeros(warmup)
    done = 0
    t_case = clock()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for k in range(warmup + cycles):
                set_targets(k * DT)
                timer.reset()
                t0 = clock()
                sol = ctrl.solve(q, v)
                t1 = clock()
                if instrumented:
                    _ = sol.diagnostics              # worked out on demand: timed apart
                t2 = clock()
                if k >= warmup:
                    i = k - warmup
                    total[i] = t1 - t0
                    diag[i] = t2 - t1
                    for p in PHASES:
                        per_phase[p][i] = timer.acc[p]
                    statuses[sol.status] += 1
                    qp_count += sol.qp_count
                    done = i + 1
                else:
                    warm[k] = t1 - t0
                if caught:
                    for w in caught:
                        warns[f"{w.category.__name__}: {str(w.message)[:90]}"] += 1
                    caught.clear()
                v = v + sol.qdd * DT
                q = pin.integrate(model, q, v * DT)
                if budget_s is not None and clock() - t_case > budget_s and k + 1 < warmup + cycles:
                    break
    finally:
        timer.restore()
    return {"total": total, "diag": diag, "phases": per_phase, "statuses": statuses, "warns": warns,
            "qp_count": qp_count, "warm": warm, "done": done, "levels": len(stack), "nx": ctrl.layout.nx,
            "finite": bool(np.all(np.isfinite(q)) and np.all(np.isfinite(v)))}


def main_cases(robots: dict[str, RobotModel], backends: list[str], cycles: int, warmup: int,
               progress: Callable[[str], None] | None = None, budget_s: float | None = None) -> list[dict]:
    specs = []
    for name, make_stack, circles in (("talos", talos_stack, ("right_hand", "left_hand")),
                                      ("tiago", tiago_stack, ("hand",))):
        if name not in robots:
            continue
        for solver in SOLVERS:
            for backend in ([None] if solver == "projection" else backends):
                specs.append((name, make_stack, circles, solver, backend))
    cases = []
    for name, make_stack, circles, solver, backend in specs:
        try:
            case = run_case(robots[name], make_stack, solver, backend, cycles, warmup, circles, budget_s=budget_s)
        except Exception as exc:  # a back-end that cannot run is reported, not fatal
            case = {"robot": name, "solver": solver, "backend": backend, "error": f"{type(exc).__name__}: {exc}"}
        cases.append(case)
        if progress:
            progress(_case_line(case))
    return cases


# ------------------------------------------------------------------ floor
def floor_talos(robot: RobotModel, cycles: int, warmup: int = 20) -> dict:
    """The floor of one Talos cycle, along the benchmark trajectory (states and rows from
    the projection controller, which needs no QP back-end): pinocchio's calls as RobotModel.update makes them plus the frame
    Jacobians, velocities and drifts the full stack's tasks extract, on a separate Data;
    and one daqp solve of the whole stack as a single weighted QP with level 0 as
    constraints (x = (q̈, f): 50 variables, 18 equality and 100 inequality rows)."""
    import daqp

    stack = talos_stack()
    ctrl = Controller(robot, stack, solver="projection")
    dynamics = FloatingBaseDynamics()
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    set_targets = moving_targets(robot, stack)
    m, d = robot.model, robot.model.createData()
    feet = [robot.frame_id(robot.contacts[c].frame) for c in ("left_foot", "right_foot")]
    others = [robot.frame_id(n) for n in ("right_hand", "left_hand")]
    clock = time.perf_counter
    parts = {k: np.empty(cycles) for k in ("whole_body", "jacobians_drifts", "qp_daqp")}
    zero = np.zeros(robot.nv)
    flags: Counter = Counter()
    size = None
    for k in range(warmup + cycles):
        set_targets(k * DT)
        t0 = clock()
        whole_body_terms(m, d, q, v, zero)
        t2 = clock()
        for f in feet:
            pin.getFrameJacobian(m, d, f, LOCAL)
            pin.getFrameVelocity(m, d, f, LOCAL)
            pin.getFrameAcceleration(m, d, f, LOCAL)
        for f in others:
            pin.getFrameJacobian(m, d, f, WORLD_ALIGNED)
            pin.getFrameVelocity(m, d, f, WORLD_ALIGNED)
            pin.getFrameClassicalAcceleration(m, d, f, WORLD_ALIGNED)
        t3 = clock()
        sol = ctrl.solve(q, v)                      # not timed: the state's rows, with the root dynamics
        levels = stack.assemble(robot, ctrl.layout, [dynamics])
        H, g, A, hi, lo, sense = _single_qp(levels, ctrl.layout.nx)
        size = (H.shape[0], int(np.sum(sense == 5)), int(np.sum(sense == 0)))
        t4 = clock()
        _, _, flag, _ = daqp.solve(H, g, A, hi, lo, sense)
        t5 = clock()
        if k >= warmup:
            i = k - warmup
            parts["whole_body"][i] = t2 - t0
            parts["jacobians_drifts"][i] = t3 - t2
            parts["qp_daqp"][i] = t5 - t4
            flags[int(flag)] += 1
        v = v + sol.qdd * DT
        q = pin.integrate(m, q, v * DT)
    pino = parts["whole_body"] + parts["jacobians_drifts"]
    out = {p: float(np.median(a) * 1e3) for p, a in parts.items()}
    out["pinocchio"] = float(np.median(pino) * 1e3)
    out["sum"] = float(np.median(pino + parts["qp_daqp"]) * 1e3)
    out["qp_size"] = {"variables": size[0], "equalities": size[1], "inequalities": size[2]}
    out["daqp_exitflags"] = {str(k): n for k, n in flags.items()}
    out["cycles"] = cycles
    return out


def sim_loop(scenario: str = "talos_balance", duration: float = 3.0, solvers=("hqp", "projection")) -> dict:
    """The whole closed loop of ``wbc run tasks/<scenario>.yaml --headless`` (controller and
    physics at 1 kHz, metrics collected, no viewer): the real-time factor (simulated time /
    wall time, > 1 is faster than real time) and the median per cycle of the controller and
    of the simulator step, per solver."""
    from .examples import SCENARIOS_DIR
    from .runner import run as run_scenario
    from .scenario import load_config
    from .sim.simulator import Simulator

    path = SCENARIOS_DIR / f"{scenario}.yaml"
    out = {"scenario": scenario, "duration_s": duration}
    for solver in solvers:
        sc = load_config(path)
        step_times: list[float] = []
        step = Simulator.step

        def timed_step(self, tau, _step=step, _acc=step_times):
            t0 = time.perf_counter()
            _step(self, tau)
            _acc.append(time.perf_counter() - t0)

        Simulator.step = timed_step
        try:
            m = run_scenario(sc, solver=solver, duration=duration)
        finally:
            Simulator.step = step
        out[solver] = {"real_time_factor": m["real_time_factor"], "fell": m["fell"],
                       "controller_median_ms": m["cycle_time"]["median"] * 1e3,
                       "simulator_median_ms": float(np.median(step_times) * 1e3)}
    return out


def _fmt_sim_loop(sl: dict) -> list[str]:
    if "missing" in sl:
        return [f"missing: {sl['missing']}"]
    out = []
    for solver in ("hqp", "projection"):
        r = sl.get(solver)
        if r:
            out.append(f"{sl['scenario']} ({sl['duration_s']:g} s simulated), {solver}: real-time factor "
                       f"{r['real_time_factor']:.2f}; median per cycle: controller {r['controller_median_ms']:.3f} ms, "
                       f"simulator {r['simulator_median_ms']:.3f} ms" + ("; FELL" if r["fell"] else ""))
    return out


def _single_qp(levels, nx: int, reg: float = 1e-6):
    """Level 0 as constraints (its equalities as equalities), every lower level's rows in
    one least-squares objective: the QP a single-QP (weighted) controller solves."""
    l0 = levels[0]
    rest = levels[1:]
    A = np.vstack([l.A for l in rest]) if rest else np.zeros((0, nx))
    b = np.concatenate([l.b for l in rest]) if rest else np.zeros(0)
    H = A.T @ A + reg * np.eye(nx)
    g = -A.T @ b
    C, lo, hi = l0.inequalities(nx)
    big = 1e20
    Cq = np.ascontiguousarray(np.vstack([l0.A, C]))
    up = np.minimum(np.concatenate([l0.b, hi]), big)
    dn = np.maximum(np.concatenate([l0.b, lo]), -big)
    sense = np.zeros(len(up), dtype=np.int32)
    sense[: l0.A.shape[0]] = 5   # equality (daqp: active + immutable)
    return np.ascontiguousarray(H), np.ascontiguousarray(g), Cq, up, dn, sense


# ------------------------------------------------------------------- peer
def _placo_available() -> str | None:
    try:
        import placo  # noqa: F401
    except Exception as exc:  # pragma: no cover - depends on the environment
        return (f"placo not importable ({type(exc).__name__}: {exc}); PlaCo is an optional peer "
                "(pip install 'wbc[peers]', pinocchio 3.8 only)")
    return None


def placo_dynamics(robot: RobotModel, cycles: int, warmup: int) -> dict:
    """PlaCo's DynamicsSolver on Talos, tasks comparable with the wbc stack: two planar foot
    contacts (hard frame tasks, 0.2 × 0.13 m soles, μ = 0.7), CoM (hard, kp 100: PlaCo has
    hard and weighted soft tasks only, and a soft CoM weighed against the hands drifts by
    several cm), both hands' poses (soft, weight 1, kp 50), posture (weight 1e-3, kp 10), joint and
    torque limits; the same CoM and hand trajectory; ``solve(True)`` integrates the state with dt = 1 ms. Timed: ``solve``
    alone, and ``update_kinematics`` + ``solve``."""
    missing = _placo_available()
    if missing:
        return {"missing": missing}
    import placo

    from .robots import package_share_dir

    os.environ.setdefault("ROS_PACKAGE_PATH", str(package_share_dir("example-robot-data")))
    pw = placo.RobotWrapper(str(robot.urdf_path), placo.Flags.ignore_collisions)
    pm = pw.model
    q = np.array(pw.state.q)
    for j in range(1, pm.njoints):                       # wbc's default posture, matched by joint name
        jw = robot.model.getJointId(pm.names[j])
        q[pm.idx_qs[j]: pm.idx_qs[j] + pm.nqs[j]] = robot.q_default[robot.model.idx_qs[jw]:
                                                                    robot.model.idx_qs[jw] + robot.model.nqs[jw]]
    pw.state.q = q
    pw.state.qd = np.zeros(pm.nv)
    pw.update_kinematics()
    s = placo.DynamicsSolver(pw)
    s.dt = DT
    s.mask_fbase(False)
    s.enable_joint_limits(True)
    s.enable_torque_limits(True)

    def gains(task, kp):
        task.kp = kp
        task.kd = 2.0 * np.sqrt(kp)

    contacts = []
    for cname in ("left_foot", "right_foot"):
        surf = robot.contacts[cname]
        ft = s.add_frame_task(surf.frame, pw.get_T_world_frame(surf.frame))
        ft.configure(cname, "hard", 1.0, 1.0)
        c = s.add_planar_contact(ft)
        c.length, c.width, c.mu = 2 * surf.half_length, 2 * surf.half_width, surf.mu
        contacts.append(c)
    com0 = np.array(pw.com_world())
    com = s.add_com_task(com0)
    com.configure("com", "hard", 1.0)        # wbc keeps the CoM strictly above the hands
    gains(com, 100.0)
    hands = []
    for i, alias in enumerate(("right_hand", "left_hand")):
        frame = robot.frames[alias]
        T0 = np.array(pw.get_T_world_frame(frame))
        ft = s.add_frame_task(frame, T0)
        ft.configure(alias, "soft", 1.0, 1.0)
        gains(ft.position(), 50.0)
        gains(ft.orientation(), 50.0)
        hands.append((ft, T0, i * np.pi))
    posture = s.add_joints_task()
    posture.set_joints({n: pw.get_joint(n) for n in pw.joint_names()})
    posture.configure("posture", "soft", 1e-3)
    gains(posture, 10.0)

    clock = time.perf_counter
    t_solve, t_cycle = np.empty(cycles), np.empty(cycles)
    ok = 0
    com_err = []
    for k in range(warmup + cycles):
        t = k * DT
        p, v, a = _sway(t)
        com.target_world, com.dtarget_world, com.ddtarget_world = com0 + p, v, a
        for ft, T0, phase in hands:
            p, v, a = _circle(t, HAND_RADIUS, HAND_FREQUENCY, phase)
            T = T0.copy()
            T[:3, 3] += p
            ft.T_world_frame = T
            pos = ft.position()
            pos.dtarget_world, pos.ddtarget_world = v, a
        t0 = clock()
        pw.update_kinematics()
        t1 = clock()
        res = s.solve(True)
        t2 = clock()
        if k >= warmup:
            i = k - warmup
            t_solve[i], t_cycle[i] = t2 - t1, t2 - t0
            ok += bool(res.success)
            com_err.append(float(np.linalg.norm(np.array(pw.com_world()) - np.array(com.target_world))))
    out = {"solve": _stats(t_solve), "cycle": _stats(t_cycle), "success": ok, "cycles": cycles,
           "com_error_mean_mm": float(np.mean(com_err) * 1e3),
           "tasks": "planar contacts x2 (hard), CoM (hard), hands pose x2 (soft 1), torso orientation (soft 0.1), "
                    "posture (soft 1e-3); joint + torque limits"}
    return out


def placo_kinematics(robot: RobotModel) -> dict:
    """PlaCo's KinematicsSolver on the IK problem of ``wbc/placo_peer.py`` (feet fixed,
    CoM xy over the feet, right hand 10 cm forward and up), median per ``solve`` call."""
    missing = _placo_available()
    if missing:
        return {"missing": missing}
    from .robots import package_share_dir

    try:
        from . import placo_peer as peer
    except Exception as exc:
        return {"missing": f"{type(exc).__name__}: {exc}"}
    q0 = robot.q_default.copy()
    robot.update(q0, np.zeros(robot.nv))
    target = robot.frame_placement(robot.frame_id("right_hand")).translation + np.array([0.10, 0.0, 0.10])
    res = peer.placo_talos_hand_ik(str(robot.urdf_path), str(package_share_dir("example-robot-data")), q0,
                                   robot.frames["right_hand"], target)
    return {"solve_median_ms": res["solve_ms_median"], "iterations": res["iterations"],
            "hand_error_mm": res["hand_error"] * 1e3}


# ---------------------------------------------------------------- scaling
def loglog_exponent(x, y) -> float:
    """Slope of log y against log x (least squares)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = (x > 0) & (y > 0) & np.isfinite(y)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])


def scaling(talos: RobotModel | None, nvs, levels, cycles: int, warmup: int,
            progress: Callable[[str], None] | None = None, budget_s: float | None = None) -> dict:
    out: dict = {"cycles": cycles, "warmup": warmup, "solvers": ["hqp", "projection"],
                 "nv": {"stack": "chain: joint limits / tip position / mid position / posture",
                        "points": []},
                 "levels": {"stack": "talos: 10 task groups (limits+contacts, CoM, hands, torso, head, "
                                     "elbows, base, posture) over 1..10 levels", "points": []}}
    for n in nvs:
        robot = chain_robot(n)
        for solver in ("hqp", "projection"):
            c = run_case(robot, chain_stack, solver, "daqp", cycles, warmup, circles=("tip",), phases=False,
                         budget_s=budget_s)
            out["nv"]["points"].append(_point(c, nv=n))
            if progress:
                progress(f"  scaling nv={n:4d} {solver:10s} " + _point_text(c))
    if talos is not None:
        for L in levels:
            for solver in ("hqp", "projection"):
                c = run_case(talos, lambda L=L: talos_levels_stack(L), solver, "daqp", cycles, warmup, phases=False,
                             budget_s=budget_s)
                out["levels"]["points"].append(_point(c, levels=L))
                if progress:
                    progress(f"  scaling levels={L:2d} {solver:10s} " + _point_text(c))
    return fit_exponents(out)


def fit_exponents(sc: dict) -> dict:
    """Log-log exponents of the median cycle time: over every point (``nv_hqp`` ...) and
    over the upper half of the range (``nv_hqp_upper`` ...), where the fixed per-cycle
    Python overhead weighs least."""
    exps, ranges = {}, {}
    for axis in ("nv", "levels"):
        for solver in ("hqp", "projection"):
            pts = [p for p in sc[axis]["points"] if p["solver"] == solver and p["median_ms"] is not None]
            x = [p[axis] for p in pts]
            y = [p["median_ms"] for p in pts]
            exps[f"{axis}_{solver}"] = loglog_exponent(x, y)
            if x:
                cut = np.median(np.unique(x))
                up = [(a, b) for a, b in zip(x, y) if a >= cut]
                exps[f"{axis}_{solver}_upper"] = loglog_exponent([a for a, _ in up], [b for _, b in up])
                ranges[axis] = f"{axis} {min(a for a, _ in up):g}-{max(a for a, _ in up):g}"
    sc["exponents"] = {k: (None if not np.isfinite(e) else e) for k, e in exps.items()}   # None: too few points
    sc["upper_range"] = ranges
    return sc


def _point(c: dict, **key) -> dict:
    p = dict(key, solver=c["solver"])
    if "error" in c:
        p.update(median_ms=None, error=c["error"])
        return p
    p.update(median_ms=c["median_ms"], p99_ms=c["p99_ms"], max_ms=c["max_ms"], cycles=c["cycles"],
             qp_per_cycle=c["qp_per_cycle"], statuses=c["statuses"])
    if "truncated" in c:
        p["truncated"] = c["truncated"]
    return p


def _point_text(c: dict) -> str:
    if "error" in c:
        return "failed: " + c["error"]
    return (f"{c['median_ms']:8.3f} ms (p99 {c['p99_ms']:.3f}, {c['qp_per_cycle']:.1f} QP/cycle)"
            + (" TRUNCATED" if "truncated" in c else ""))


def plot_scaling(sc: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, axis, xlabel in ((axes[0], "nv", "nv (serial chain)"), (axes[1], "levels", "levels (Talos, same tasks)")):
        xs = set()
        for solver, style, color in (("hqp", "o-", "C0"), ("projection", "s--", "C1")):
            pts = [p for p in sc[axis]["points"] if p["solver"] == solver and p["median_ms"] is not None]
            if not pts:
                continue
            x = np.array([p[axis] for p in pts], float)
            xs.update(x.tolist())
            e = sc["exponents"][f"{axis}_{solver}"]
            ax.plot(x, [p["median_ms"] for p in pts], style, color=color, label=f"{solver} median (exponent {_num(e)})")
            ax.plot(x, [p["p99_ms"] for p in pts], ":", color=color, alpha=0.5, label=f"{solver} p99")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(sorted(xs))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(xlabel)
        ax.set_ylabel("cycle time (ms)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("cycle time vs nv")
    axes[1].set_title("cycle time vs number of levels")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=72)
    plt.close(fig)


# ---------------------------------------------------------------- machine
def _openblas_libs() -> list[tuple[str, object, object]]:
    """(path, get_num_threads, set_num_threads) of every OpenBLAS this process has loaded."""
    libs = []
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({ln.split()[-1] for ln in fh if "openblas" in ln.lower() and ln.split()[-1].startswith("/")})
    except OSError:
        return libs
    for p in paths:
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        for pre, suf in (("scipy_openblas_", "64_"), ("scipy_openblas_", ""), ("openblas_", "64_"), ("openblas_", "")):
            get, put = getattr(lib, f"{pre}get_num_threads{suf}", None), getattr(lib, f"{pre}set_num_threads{suf}", None)
            if get is not None and put is not None:
                libs.append((p, get, put))
                break
    return libs


def set_blas_threads(n: int) -> None:
    import scipy.linalg  # noqa: F401  (load scipy's own OpenBLAS too)
    for _, _, put in _openblas_libs():
        put(int(n))


def _svd_probe(sizes=(24, 48, 96), reps: int = 20) -> dict:
    """Median time (ms) of numpy's full SVD of an n × n matrix (what the cascade does per
    level), with the current BLAS threads and with one thread."""
    libs = _openblas_libs()
    rng = np.random.default_rng(0)
    out = {}
    for n in sizes:
        A = rng.standard_normal((n, n))
        row = {}
        for mode in ("default", "1 thread"):
            saved = [get() for _, get, _ in libs]
            if mode == "1 thread":
                for _, _, put in libs:
                    put(1)
            ts = []
            for _ in range(reps):
                t0 = time.perf_counter()
                np.linalg.svd(A, full_matrices=True)
                ts.append(time.perf_counter() - t0)
            for (_, _, put), s in zip(libs, saved):
                put(s)
            row[mode] = float(np.median(ts) * 1e3)
        out[str(n)] = row
    return out


def machine_info() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for ln in fh:
                if ln.startswith("model name"):
                    cpu = ln.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    versions = {}
    for pkg in ("numpy", "scipy", "pin", "daqp", "proxsuite", "quadprog", "osqp", "qpsolvers", "placo"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    import scipy.linalg  # noqa: F401
    blas = {os.path.basename(p): get() for p, get, _ in _openblas_libs()}
    info = {"cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "numpy": versions["numpy"], "pin": versions["pin"],
            "versions": versions, "blas_threads": blas,
            "env_threads": {k: os.environ[k] for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
                            if k in os.environ}}
    try:
        info["load_average_start"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    return info


# ----------------------------------------------------------------- output
def _case_line(c: dict) -> str:
    be = c.get("backend") or "-"
    if "error" in c:
        return f"{c['robot']:6s} {c['solver']:10s} {be:9s} FAILED: {c['error']}"
    ph = c.get("phases", {})
    st = ",".join(f"{k}:{n}" for k, n in c["statuses"].items())
    return (f"{c['robot']:6s} {c['solver']:10s} {be:9s} {c['levels']:2d} {c['nv']:3d} "
            f"{c['median_ms']:7.3f} {c['p99_ms']:7.3f} {c['max_ms']:7.2f} | "
            + " ".join(f"{ph.get(p, float('nan')):6.3f}" for p in (*PHASES, "other"))
            + f" | {c.get('phase_coverage', float('nan')):5.3f} {c['qp_per_cycle']:4.1f}"
            + f" {c.get('diagnostics_ms', float('nan')):6.3f} {st}"
            + (f" TRUNCATED ({c['cycles']} cycles)" if "truncated" in c else "")
            + f" warm-up max {c['warmup_max_ms']:.0f} ms")


HEADER = ("robot  solver     backend   lv  nv  median     p99     max | update   rows  solve finish  other"
          " | cover qp/c  diag status")


def cases_markdown(cases: list[dict]) -> str:
    rows = ["| robot | solver | backend | levels | nv | median ms | p99 ms | max ms | update | rows | solve | "
            "finish | other | coverage | QPs/cycle | diagnostics ms | statuses |",
            "|" + " --- |" * 17]
    for c in cases:
        be = c.get("backend") or "-"
        if "error" in c:
            rows.append(f"| {c['robot']} | {c['solver']} | {be} | failed: {c['error']} |" + " |" * 13)
            continue
        ph = c["phases"]
        st = ", ".join(f"{k} {n}" for k, n in c["statuses"].items())
        if "truncated" in c:
            st += f" (truncated: {c['cycles']} cycles)"
        rows.append(f"| {c['robot']} | {c['solver']} | {be} | {c['levels']} | {c['nv']} | {c['median_ms']:.3f} | "
                    f"{c['p99_ms']:.3f} | {c['max_ms']:.2f} | " + " | ".join(f"{ph[p]:.3f}" for p in (*PHASES, "other"))
                    + f" | {c['phase_coverage']:.3f} | {c['qp_per_cycle']:.2f} | {c.get('diagnostics_ms', float('nan')):.3f}"
                    f" | {st} |")
    return "\n".join(rows)


def _fmt_floor(fl: dict) -> str:
    if "missing" in fl:
        return f"missing: {fl['missing']}"
    s = fl["qp_size"]
    return (f"whole-body terms (kinematics, joint Jacobians, CRBA, NLE, CoM) {fl['whole_body']:.3f} + "
            f"frame Jacobians/drifts {fl['jacobians_drifts']:.3f} = pinocchio {fl['pinocchio']:.3f} ms; "
            f"daqp QP ({s['variables']} vars, {s['equalities']} eq, {s['inequalities']} ineq) "
            f"{fl['qp_daqp']:.3f} ms; sum {fl['sum']:.3f} ms (medians)")


def _fmt_placo(pd: dict, pk: dict) -> list[str]:
    lines = []
    if "missing" in pd:
        lines.append(f"PlaCo DynamicsSolver (Talos): missing: {pd['missing']}")
    else:
        lines.append(f"PlaCo DynamicsSolver (Talos): solve median {pd['solve']['median_ms']:.3f} ms "
                     f"(p99 {pd['solve']['p99_ms']:.3f}, max {pd['solve']['max_ms']:.2f}); update_kinematics + solve "
                     f"median {pd['cycle']['median_ms']:.3f} ms; {pd['success']}/{pd['cycles']} successful; "
                     f"mean CoM error {pd['com_error_mean_mm']:.2f} mm")
    if "missing" in pk:
        lines.append(f"PlaCo KinematicsSolver (wbc/placo_peer.py IK): missing: {pk['missing']}")
    else:
        lines.append(f"PlaCo KinematicsSolver (wbc/placo_peer.py IK): solve median {pk['solve_median_ms']:.3f} ms "
                     f"over {pk['iterations']} iterations, hand error {pk['hand_error_mm']:.3f} mm")
    return lines


def _fmt_scaling(sc: dict) -> list[str]:
    e, up = sc["exponents"], sc.get("upper_range", {})
    lines = []
    for axis in ("nv", "levels"):
        if f"{axis}_hqp" not in e:
            continue
        line = (f"{axis} sweep ({sc[axis]['stack']}): exponent hqp {_num(e[f'{axis}_hqp'])}, "
                f"projection {_num(e[f'{axis}_projection'])}")
        if f"{axis}_hqp_upper" in e:
            line += (f"; over {up.get(axis, 'the upper half')}: hqp {_num(e[f'{axis}_hqp_upper'])}, "
                     f"projection {_num(e.get(f'{axis}_projection_upper'))}")
        lines.append(line)
    return lines


def _num(x, fmt: str = ".2f") -> str:
    return "n/a" if x is None else format(x, fmt)


def scaling_markdown(sc: dict) -> str:
    out = ["| nv | hqp ms | projection ms |", "| --- | --- | --- |"]
    for n in sorted({p["nv"] for p in sc["nv"]["points"]}):
        row = {p["solver"]: p["median_ms"] for p in sc["nv"]["points"] if p["nv"] == n}
        out.append(f"| {n} | {row.get('hqp', float('nan')):.3f} | {row.get('projection', float('nan')):.3f} |")
    out += ["", "| levels | hqp ms | projection ms |", "| --- | --- | --- |"]
    for n in sorted({p["levels"] for p in sc["levels"]["points"]}):
        row = {p["solver"]: p["median_ms"] for p in sc["levels"]["points"] if p["levels"] == n}
        out.append(f"| {n} | {row.get('hqp', float('nan')):.3f} | {row.get('projection', float('nan')):.3f} |")
    return "\n".join(out)


def results_markdown(res: dict) -> str:
    m = res["machine"]
    fl = res.get("floor_ms", {}).get("talos_parts", {"missing": "not run"})
    pl = res.get("placo", {})
    text = [
        "# wbc bench results",
        "",
        f"Command: `{res['command']}` (total {res['wall_s']:.0f} s).",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores, {m['platform']}; Python {m['python']}, numpy {m['numpy']}, "
        f"pin {m['pin']}; BLAS threads {m['blas_threads']}; load average at start {m.get('load_average_start')}, "
        f"at end {m.get('load_average_end')}.",
        "",
        f"Cycles: {res['settings']['cycles']} timed after {res['settings']['warmup']} warm-up, dt = 1 ms, targets "
        f"moving every cycle (CoM ±{COM_AMPLITUDE * 100:.0f} cm at {COM_FREQUENCY} Hz, hands on "
        f"{HAND_RADIUS * 100:.0f} cm circles at {HAND_FREQUENCY} Hz), state integrated from q̈. Times in ms. "
        "Median, p99 and max come from a pass with nothing but the controller; the phases and the diagnostics "
        "from a second pass over the same trajectory with each phase wrapped in a timer and sol.diagnostics read "
        "after each cycle. Phases are medians (update = robot.update, rows = stack.layout + stack.assemble, "
        "solve = solver, finish = Controller._finish, other = the rest of Controller.solve); coverage = Σ mean "
        "phase / mean cycle of that second pass.",
        "",
        cases_markdown(res["cases"]),
        "",
        "## Floor (Talos, same trajectory)",
        "",
        _fmt_floor(fl),
        "",
        "## Closed loop (controller + physics, no viewer)",
        "",
        *[f"- {ln}" for ln in _fmt_sim_loop(res.get("sim_loop", {"missing": "not run"}))],
        "",
        "## Peer (PlaCo)",
        "",
        *[f"- {ln}" for ln in _fmt_placo(pl.get("talos_dynamics", {"missing": "not run"}),
                                        pl.get("talos_kinematics", {"missing": "not run"}))],
        "",
        "## Scaling",
        "",
        *[f"- {ln}" for ln in _fmt_scaling(res["scaling"])],
        "",
        f"Median cycle time ({res['scaling']['cycles']} cycles per point); plot: `scaling.png`.",
        "",
        scaling_markdown(res["scaling"]),
        "",
        "## Notes",
        "",
        *[f"- {ln}" for ln in _notes(res)],
        "",
    ]
    return "\n".join(text)


def _notes(res: dict) -> list[str]:
    """What a reader should not miss: truncated or failed cases, slow outliers, warnings."""
    out = []
    for c in res["cases"]:
        name = f"{c['robot']} {c['solver']}" + (f"/{c['backend']}" if c.get("backend") else "")
        if "error" in c:
            out.append(f"{name}: failed: {c['error']}")
            continue
        if "truncated" in c:
            out.append(f"{name}: {c['truncated']}")
        if c["max_ms"] > 100:
            out.append(f"{name}: slowest cycle {c['max_ms']:.0f} ms (p99 {c['p99_ms']:.0f} ms)")
        for msg, n in (c.get("warnings") or {}).items():
            if "SparseConversion" in msg or "PendingDeprecation" in msg:
                continue
            out.append(f"{name}: {n} × {msg}")
    svd = res["machine"].get("svd_ms")
    if svd:
        out.append("SVD probe (numpy full n × n SVD, median ms, default BLAS threads / 1 thread): "
                   + ", ".join(f"n={n}: {r['default']:.3f} / {r['1 thread']:.3f}" for n, r in svd.items()))
    return out


# -------------------------------------------------------------------- run
def run(cycles: int = 2000, warmup: int = WARMUP, backends=BACKENDS, robots=("talos", "tiago"),
        floor: bool = True, peer: bool = True, sim: bool = True, scaling_nv=CHAIN_NV, scaling_levels=LEVELS,
        scaling_cycles: int = 300, scaling_warmup: int = 30, budget_s: float | None = None, svd_reps: int = 20,
        progress: Callable[[str], None] | None = None) -> dict:
    """The whole benchmark as a dict (what ``--json`` writes). ``budget_s``: wall-time
    budget per case (see :func:`run_case`)."""
    from .robots import load_robot

    t_start = time.perf_counter()
    say = progress or (lambda s: None)
    res: dict = {"machine": machine_info()}
    res["machine"]["svd_ms"] = _svd_probe(reps=svd_reps) if svd_reps else None
    loaded = {name: load_robot(name) for name in robots}
    res["settings"] = {"cycles": cycles, "warmup": warmup, "dt": DT, "backends": list(backends),
                       "budget_s_per_case": budget_s}
    say(HEADER)
    res["cases"] = main_cases(loaded, list(backends), cycles, warmup, progress=say, budget_s=budget_s)
    talos = loaded.get("talos")
    if floor and talos is not None:
        fl = floor_talos(talos, min(cycles, 500), min(warmup, 50))
        res["floor_ms"] = {"talos": fl["sum"], "talos_parts": fl}
        say("floor: " + _fmt_floor(fl))
    if sim and talos is not None:
        res["sim_loop"] = sim_loop(duration=1.0 if cycles < 1000 else 5.0)
        for ln in _fmt_sim_loop(res["sim_loop"]):
            say(ln)
    if peer and talos is not None:
        try:
            pd = placo_dynamics(talos, cycles, warmup)
        except Exception as exc:
            pd = {"missing": f"{type(exc).__name__}: {exc}"}
        try:
            pk = placo_kinematics(talos)
        except Exception as exc:
            pk = {"missing": f"{type(exc).__name__}: {exc}"}
        dyn = pd["solve"]["median_ms"] if "solve" in pd else None
        # "talos": the issue's key, the DynamicsSolver on the same stack (the peer of the cases)
        res["placo_ms"] = {"talos": dyn, "talos_dynamics": dyn, "talos_kinematics": pk.get("solve_median_ms")}
        res["placo"] = {"talos_dynamics": pd, "talos_kinematics": pk}
        for ln in _fmt_placo(pd, pk):
            say(ln)
    if scaling_nv or scaling_levels:
        res["scaling"] = scaling(talos, scaling_nv, scaling_levels, scaling_cycles, scaling_warmup, progress=say,
                                 budget_s=budget_s)
        for ln in _fmt_scaling(res["scaling"]):
            say(ln)
    try:
        res["machine"]["load_average_end"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    res["wall_s"] = time.perf_counter() - t_start
    return res


def _backends(values) -> list[str]:
    out = []
    for v in values:
        out += [b for b in v.replace(",", " ").split() if b]
    return out


def _command(args) -> str:
    parts = ["wbc", "bench"]
    if args.quick:
        parts.append("--quick")
    if args.cycles != 2000:
        parts += ["--cycles", str(args.cycles)]
    if _backends(args.backends) != list(BACKENDS):
        parts += ["--backends", ",".join(_backends(args.backends))]
    if args.out_dir is not None:
        parts += ["--out-dir", args.out_dir]
    if args.json:
        parts += ["--json", args.json]
    if args.budget is not None:
        parts += ["--budget", f"{args.budget:g}"]
    if args.blas_threads is not None:
        parts += ["--blas-threads", str(args.blas_threads)]
    return " ".join(parts)


def _cmd_bench(args) -> int:
    t0 = time.perf_counter()
    if args.blas_threads is not None:
        set_blas_threads(args.blas_threads)
    backends = _backends(args.backends)
    unknown = [b for b in backends if b not in BACKENDS]
    if unknown:
        print(f"note: back-ends {unknown} are not among {list(BACKENDS)}; trying them anyway", file=sys.stderr)
    if args.quick:
        kw = dict(cycles=min(args.cycles, QUICK_CYCLES), warmup=QUICK_WARMUP, scaling_nv=QUICK_CHAIN_NV,
                  scaling_levels=QUICK_LEVELS, scaling_cycles=40, scaling_warmup=10, svd_reps=3,
                  budget_s=QUICK_BUDGET if args.budget is None else args.budget)
    else:
        kw = dict(cycles=args.cycles, warmup=WARMUP, budget_s=FULL_BUDGET if args.budget is None else args.budget)

    def say(line: str) -> None:
        print(f"[{time.perf_counter() - t0:6.1f} s] {line}", flush=True)

    res = run(backends=backends, progress=say, **kw)
    res["command"] = _command(args)
    res["settings"]["quick"] = bool(args.quick)
    out_dir = Path(args.out_dir if args.out_dir is not None else "benchmarks")
    # --quick leaves the full run's files alone unless an output directory is named
    if not args.quick or args.out_dir is not None:
        plot_scaling(res["scaling"], out_dir / "scaling.png")
    res["wall_s"] = time.perf_counter() - t0
    if not args.quick:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "results.md").write_text(results_markdown(res))
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(res, indent=1, default=_json_default) + "\n")
    failed = [c for c in res["cases"] if "error" in c]
    print(f"done in {res['wall_s']:.1f} s" + (f"; {len(failed)} case(s) failed" if failed else ""))
    return 1 if failed else 0


def _json_default(o):
    """numpy values as plain JSON (:func:`wbc.jsonable.plain`), anything else as its text."""
    try:
        return plain(o)
    except TypeError:
        return str(o)


def add_parser(sub) -> None:
    """Register the ``bench`` sub-command on an argparse subparsers object."""
    p = sub.add_parser("bench", help="cycle-time benchmark: cases, phases, floor, PlaCo peer, scaling",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="short run (< 1 min): 100 cycles, fewer scaling points; "
                   "writes no results.md, and no scaling.png unless --out-dir is given")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--out-dir", metavar="DIR", default=None, help="results.md and scaling.png go here (default benchmarks/)")
    p.add_argument("--cycles", type=int, default=2000, metavar="N", help="timed cycles per case (default 2000)")
    p.add_argument("--backends", nargs="+", default=[",".join(BACKENDS)], metavar="NAME",
                   help="QP back-ends for hqp and weighted, comma or space separated (default: all of "
                        + ", ".join(BACKENDS) + ")")
    p.add_argument("--budget", type=float, default=None, metavar="SECONDS",
                   help=f"wall-time budget per case; a case that uses it up stops and is marked truncated "
                        f"(default {FULL_BUDGET:g} s, {QUICK_BUDGET:g} s with --quick)")
    p.add_argument("--blas-threads", type=int, default=None, metavar="N",
                   help="set the OpenBLAS thread count first (default: leave it as the environment set it)")
    p.set_defaults(fn=_cmd_bench)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wbc.bench")
    sub = parser.add_subparsers(dest="cmd")
    add_parser(sub)
    args = parser.parse_args(["bench", *(sys.argv[1:] if argv is None else argv)])
    return args.fn(args)


if __name__ == "__main__":
    sys.exit(main())
