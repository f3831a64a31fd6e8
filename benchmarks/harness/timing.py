"""Timing one case: a controller driven along the bench trajectory, cycle times and phases.

A case is a robot, a stack, a solver and a QP back-end. :func:`run_case` runs
``warmup`` + ``cycles`` control cycles along :mod:`.trajectory` from the robot's default
posture at rest and reports the median, p99 and max time of ``Controller.solve`` (ms),
and the split by phase: model update (``robot.update``), task rows (``stack.layout`` +
``stack.assemble``), solve (the solver's methods) and torques (``Controller._finish``),
measured in a second pass by :class:`PhaseTimer`. :func:`main_cases` runs Talos's and
TIAGo's stacks with every solver and back-end.
"""

from __future__ import annotations

import time
import warnings
from collections import Counter
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from wbc.controller.cycle import Controller
from wbc.controller.solver_names import SOLVERS as ALL_SOLVERS
from wbc.robot.model import RobotModel
from wbc.stack import Stack

from .stacks import talos_stack, tiago_stack
from .trajectory import DT, moving_targets

#: the phases of one cycle, in order (see :class:`PhaseTimer`)
PHASES = ("update", "rows", "solve", "finish")
#: the solvers of the cases, in the order they are run and reported: the projection
#: (which needs no QP back-end) first
SOLVERS = ("projection", *(s for s in ALL_SOLVERS if s != "projection"))


# ----------------------------------------------------------- phase timing
class PhaseTimer:
    """Times the controller's phases through its ``phase_clock`` hook: the controller calls
    :meth:`lap` after each phase with the time the phase started (``phase`` None: a stretch
    not counted in any phase, e.g. building the Problem); what is left of a cycle is
    "other"."""

    def __init__(self) -> None:
        self.acc = dict.fromkeys(PHASES, 0.0)
        self._ctrl: Controller | None = None

    def lap(self, phase: str | None, t0: float) -> float:
        t = time.perf_counter()
        if phase is not None:
            self.acc[phase] += t - t0
        return t

    def instrument(self, ctrl: Controller) -> None:
        ctrl.phase_clock = self
        self._ctrl = ctrl

    def reset(self) -> None:
        for k in self.acc:
            self.acc[k] = 0.0

    def restore(self) -> None:
        if self._ctrl is not None:
            self._ctrl.phase_clock = None
            self._ctrl = None


# -------------------------------------------------------------- one case
def stats(total: np.ndarray) -> dict:
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

    ``budget_s``: wall-time budget of each pass after its first cycle (which compiles the kernels
    on a cold cache; its time is ``warmup_max_ms``); when it is used up the pass stops after
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
    out.update(stats(first["total"][:done]))
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


class CycleRun:
    """One case's controller driven along the bench trajectory from the robot's default
    posture at rest: :meth:`step` sets the targets of cycle k, times ``ctrl.solve`` and
    integrates the state with its q̈ (neither timed)."""

    def __init__(self, robot: RobotModel, make_stack: Callable[[], Stack], solver: str, backend: str | None,
                 circles: tuple[str, ...]) -> None:
        self.robot = robot
        self.stack = make_stack()
        self.ctrl = Controller(robot, self.stack, solver=solver, backend=backend or "daqp")
        self.q, self.v = robot.q_default.copy(), np.zeros(robot.nv)
        robot.update(self.q, self.v)
        self._targets = moving_targets(robot, self.stack, circles)

    def step(self, k: int, before_solve: Callable[[], None] | None = None) -> tuple[float, object]:
        """Cycle k: (the time of ``ctrl.solve`` in s, its Solution); ``before_solve`` is
        called after the targets are set, just before the timed call."""
        self._targets(k * DT)
        if before_solve is not None:
            before_solve()
        clock = time.perf_counter
        t0 = clock()
        sol = self.ctrl.solve(self.q, self.v)
        t1 = clock()
        self.v = self.v + sol.qdd * DT
        self.q = pin.integrate(self.robot.model, self.q, self.v * DT)
        return t1 - t0, sol


def _timed_pass(robot: RobotModel, make_stack: Callable[[], Stack], solver: str, backend: str | None,
                cycles: int, warmup: int, circles: tuple[str, ...], instrumented: bool,
                budget_s: float | None) -> dict:
    """One pass of :func:`run_case` (a :class:`CycleRun`)."""
    run = CycleRun(robot, make_stack, solver, backend, circles)
    ctrl = run.ctrl
    timer = PhaseTimer()
    if instrumented:
        timer.instrument(ctrl)
    total = np.empty(cycles)
    diag = np.empty(cycles)
    per_phase = {p: np.empty(cycles) for p in PHASES}
    statuses: Counter = Counter()
    warns: Counter = Counter()
    qp_count = 0
    clock = time.perf_counter
    warm = np.zeros(warmup)
    done = 0
    t_case = clock()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for k in range(warmup + cycles):
                dt, sol = run.step(k, timer.reset)
                t1 = clock()
                if instrumented:
                    _ = sol.diagnostics              # worked out on demand: timed apart
                t2 = clock()
                if k >= warmup:
                    i = k - warmup
                    total[i] = dt
                    diag[i] = t2 - t1
                    for p in PHASES:
                        per_phase[p][i] = timer.acc[p]
                    statuses[sol.status] += 1
                    qp_count += sol.qp_count
                    done = i + 1
                else:
                    warm[k] = dt
                if caught:
                    for w in caught:
                        warns[f"{w.category.__name__}: {str(w.message)[:90]}"] += 1
                    caught.clear()
                if k == 0:
                    # the first cycle compiles the kernels when numba's cache is cold (~15-30 s on a
                    # fresh clone): a one-time cost, reported in warmup_max_ms, not spent from the budget
                    t_case = clock()
                if budget_s is not None and clock() - t_case > budget_s and k + 1 < warmup + cycles:
                    break
    finally:
        timer.restore()
    return {"total": total, "diag": diag, "phases": per_phase, "statuses": statuses, "warns": warns,
            "qp_count": qp_count, "warm": warm, "done": done, "levels": len(run.stack), "nx": ctrl.layout.nx,
            "finite": bool(np.all(np.isfinite(run.q)) and np.all(np.isfinite(run.v)))}


def main_cases(robots: dict[str, RobotModel], backends: list[str], cycles: int, warmup: int,
               on_case: Callable[[dict], None] | None = None, budget_s: float | None = None) -> list[dict]:
    """The cases of the bench: Talos's full stack (:func:`.stacks.talos_stack`, both hands on
    circles) and TIAGo's (its hand on a circle), each with every solver of :data:`SOLVERS`
    and, for the QP solvers, every one of ``backends``; ``on_case(case)`` after each. A
    case that raises is reported with its ``error``, not fatal."""
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
        if on_case:
            on_case(case)
    return cases
