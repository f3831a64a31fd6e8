"""Run-time faults of the control cycle: detection, the hold-then-stop policy, the counters.

:meth:`wbc.Controller.solve` runs every cycle through :meth:`FaultMonitor.cycle`. A cycle
is *faulty* when (detected within that cycle, counter in brackets):

- the measured state has a NaN or an inf in q or v (``state_faults``);
- the measured state is stale (``stale_cycles``, only with ``FaultPolicy.detect_stale``):
  (q, v) bitwise equal to the previous cycle's while v ≠ 0, which no moving robot's
  sensors give (q must integrate v), a sensor that stopped updating does;
- the solve raised (``solver_errors``: a QP back-end that threw, an internal error);
- the solve failed (``solve_failures``: ``Solution.status == "failed"``, a non-finite x
  or a QP that no fallback answered; see :class:`wbc.Controller`);
- the solve overran its budget (``solve_timeouts``, with ``FaultPolicy.solve_timeout``):
  its wall time, measured around the whole solve, exceeded the budget; the late answer is
  discarded (on a real robot its deadline has passed).

A faulty cycle is *held* (``held_cycles``): the torque is the hold torque

    τ_hold = sat(τ_good − k_d diag(M) v̂),

τ_good the last accepted cycle's torque (before the first, gravity compensation g(q) at
the last state the model saw), k_d = ``FaultPolicy.damping`` (1/s), M the joint-space
inertia at the last state the model was updated at (kg·m², kg), v̂ the measured velocity
with its non-finite entries taken as 0 (rad/s, m/s), sat the clip at ±τ_max (the robot's
actuator limits), zero on unactuated dofs: |τ_hold,i| ≤ τ_max,i whatever the fault, and the
damping term adds at most k_d M_ii |v̂_i| to joint i before the clip. q̈ = 0 and the contact
forces are the last accepted ones. After ``FaultPolicy.max_hold_cycles`` consecutive
faulty cycles the next faulty one *stops* the controller (``stops``): its status is
``"stopped"``, latched (every later cycle returns the hold torque with that status, no
solve) until :meth:`FaultMonitor.reset`; a closed-loop run ends there (exit status 1).
An accepted cycle resets the consecutive count.

:func:`simulation_diverged` is the runner's test of the simulator after each step (one
that blew up: see :func:`diverged`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numba as nb
import numpy as np

from wbc.errors import SolverError, WbcError

#: the counters of :class:`FaultMonitor`, in the order the metrics list them
COUNTERS = ("state_faults", "stale_cycles", "solver_errors", "solve_failures", "solve_timeouts",
            "held_cycles", "stops")

#: a simulated speed beyond this (m/s, rad/s) is a simulator that diverged: no robot here
#: comes within two orders of magnitude of it (Talos' fastest joint: 6.3 rad/s)
DIVERGED_SPEED = 1e3
#: a simulated position beyond this (m; joint angles are far below it) likewise
DIVERGED_POSITION = 1e4


@dataclass
class FaultPolicy:
    """The fault policy's parameters (module docstring).

    ``max_hold_cycles``: consecutive faulty cycles held before the stop (20: 20 ms at
    dt = 1 ms); ``damping`` k_d (1/s) of the hold torque's joint damping −k_d M_ii v_i
    (10 /s: a joint's velocity decays with a time constant of ~0.1 s, held alone);
    ``detect_stale``: treat a repeated (q, v) with v ≠ 0 as a fault (off by default: a
    caller may solve one state twice; the runner turns it on); ``solve_timeout``: the
    per-cycle budget of the solve's wall time (s), None for none."""

    max_hold_cycles: int = 20
    damping: float = 10.0
    detect_stale: bool = False
    solve_timeout: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.max_hold_cycles, int) and self.max_hold_cycles >= 0):
            raise SolverError(f"FaultPolicy.max_hold_cycles must be an integer >= 0, got {self.max_hold_cycles!r}")
        if not (math.isfinite(self.damping) and self.damping >= 0):
            raise SolverError(f"FaultPolicy.damping must be a finite number >= 0 (1/s), got {self.damping!r}")
        if self.solve_timeout is not None and not self.solve_timeout > 0:
            raise SolverError(f"FaultPolicy.solve_timeout must be > 0 (s) or None, got {self.solve_timeout!r}")


def hold_torque(tau_good: np.ndarray, M: np.ndarray, v: np.ndarray, actuated: np.ndarray,
                damping: float) -> np.ndarray:
    """τ_good − k_d diag(M) v̂ on the actuated dofs, 0 elsewhere (module docstring; the
    caller saturates it). Non-finite entries of v count as 0."""
    tau = np.zeros_like(tau_good)
    vh = np.where(np.isfinite(v), v, 0.0)
    tau[actuated] = tau_good[actuated] - damping * np.diag(M)[actuated] * vh[actuated]
    return tau


@nb.njit(cache=True)
def _finite(q, v):
    """Whether every entry of q and v is finite (``np.isfinite(·).all()`` of both, one pass). Alone:
    :meth:`FaultMonitor.cycle`'s common case (two arguments and a bool across, not five and a tuple:
    ~1 µs less a cycle with cold caches)."""
    for x in q:
        if not math.isfinite(x):
            return False
    for x in v:
        if not math.isfinite(x):
            return False
    return True


@nb.njit(cache=True)
def _state_check(q, v, last_q, last_v, has_last):
    """(whether every entry of q and v is finite (:func:`_finite`), whether (q, v) is stale:
    ``has_last``, v ≠ 0 and q, v equal entry by entry to ``last_q``, ``last_v`` (of the same
    sizes)). The same decisions as ``np.isfinite(·).all()``, ``v.any()`` and ``np.array_equal``."""
    if not _finite(q, v):
        return False, False
    moving = False
    for x in v:
        if x != 0.0:
            moving = True
            break
    if not (has_last and moving):
        return True, False
    for i in range(q.shape[0]):
        if q[i] != last_q[i]:
            return True, False
    for i in range(v.shape[0]):
        if v[i] != last_v[i]:
            return True, False
    return True, True


class FaultMonitor:
    """The fault policy of one controller: detection, counting, the latched stop."""

    def __init__(self, policy: FaultPolicy | None = None) -> None:
        self.policy = policy or FaultPolicy()
        self.counts = dict.fromkeys(COUNTERS, 0)
        self.consecutive = 0
        #: the reason of the stop, "" while running
        self.stopped = ""
        self._last_state: tuple[np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        """Clear the stop and the consecutive count (the counters are kept)."""
        self.stopped, self.consecutive, self._last_state = "", 0, None

    def state_fault(self, q, v) -> tuple[str, str] | None:
        """(counter, message) of a non-finite or stale measured state, else None; a state
        of the wrong shape passes (the solve refuses it with its own error)."""
        if not (type(q) is np.ndarray and q.dtype is _FLOAT):     # (a measured state usually is: no call)
            q = np.asarray(q, dtype=float)
        if not (type(v) is np.ndarray and v.dtype is _FLOAT):
            v = np.asarray(v, dtype=float)
        last = self._last_state
        if q.ndim == 1 and v.ndim == 1 and (last is None or (last[0].shape == q.shape and last[1].shape == v.shape)):
            # a measured state's usual case in one compiled pass: finite, and equal to the last or not
            finite, stale = _state_check(q, v, _NO_STATE if last is None else last[0],
                                         _NO_STATE if last is None else last[1], last is not None)
            if finite:
                if not self.policy.detect_stale:
                    return None
                self._last_state = (q.copy(), v.copy())
                if stale:
                    return "stale_cycles", "measured state stale: (q, v) repeats the previous cycle's while v ≠ 0"
                return None
        # a sum of squares is finite iff every entry is (or it overflowed: checked entry by
        # entry); q·q is one BLAS call, cheaper than a reduction through numpy's ufuncs
        squares = q.dot(q) + v.dot(v) if q.ndim == 1 and v.ndim == 1 else q.sum() + v.sum()
        if not math.isfinite(squares) and not (np.isfinite(q).all() and np.isfinite(v).all()):
            bad = [f"{name}[{i}]" for name, x in (("q", q), ("v", v)) for i in np.flatnonzero(~np.isfinite(x))[:4]]
            return "state_faults", f"measured state not finite ({', '.join(bad)})"
        if not self.policy.detect_stale:
            return None
        last = self._last_state
        self._last_state = (q.copy(), v.copy())
        if last is not None and v.any() and np.array_equal(q, last[0]) and np.array_equal(v, last[1]):
            return "stale_cycles", "measured state stale: (q, v) repeats the previous cycle's while v ≠ 0"
        return None

    def cycle(self, q, v, solve: Callable, hold: Callable):
        """One cycle under the policy: ``solve(q, v)`` -> Solution unless the state is
        faulty; ``hold(v, message)`` -> the hold Solution. Returns the Solution with its
        ``fault`` set (the counter's name, "" for an accepted cycle)."""
        if self.stopped:
            return self._stopped(hold(v, self.stopped))
        if (not self.policy.detect_stale and type(q) is np.ndarray is type(v) and q.dtype is _FLOAT is v.dtype
                and q.ndim == 1 == v.ndim and _finite(q, v)):
            fault = None            # state_fault's common case (finite, no stale detection) without its call
        else:
            fault = self.state_fault(q, v)
        sol = None
        if fault is None:
            budget = self.policy.solve_timeout
            t0 = 0.0 if budget is None else time.perf_counter()     # timed only against a budget
            try:
                sol = solve(q, v)
            except WbcError as exc:
                if not isinstance(exc, SolverError):
                    raise                   # bad input (a wrong state shape, a bad target): the caller's
                fault = ("solver_errors", f"the solver raised {type(exc).__name__}: {exc}")
            except Exception as exc:  # noqa: BLE001 (a back-end that threw: a fault, held and counted)
                fault = ("solver_errors", f"the solver raised {type(exc).__name__}: {exc}")
            else:
                if sol.status == "failed":
                    fault = ("solve_failures", f"solve failed: {sol.message}")
                elif budget is not None and (elapsed := time.perf_counter() - t0) > budget:
                    fault = ("solve_timeouts", f"the solve took {elapsed * 1e3:.3g} ms, over its budget of "
                                               f"{budget * 1e3:.3g} ms (answer discarded)")
                    sol = None
                else:
                    self.consecutive = 0
                    return sol
        kind, message = fault
        self.counts[kind] += 1
        self.consecutive += 1
        if sol is None:
            sol = hold(v, message)
        sol.fault = kind
        if self.consecutive > self.policy.max_hold_cycles:
            self.stopped = (f"stopped after {self.consecutive} consecutive faulty cycles "
                            f"(> max_hold_cycles = {self.policy.max_hold_cycles}); last: {message}")
            self.counts["stops"] += 1
            sol.message = self.stopped
            return self._stopped(sol)
        self.counts["held_cycles"] += 1
        return sol

    def _stopped(self, sol):
        sol.status = "stopped"
        sol.fault = sol.fault or "stopped"
        return sol


_FLOAT = np.dtype(float)
_NO_STATE = np.zeros(0)


def diverged(q: np.ndarray, v: np.ndarray) -> str:
    """Why the simulated state (q, v) is one of a simulator that blew up, or "": a NaN or
    inf, a speed beyond :data:`DIVERGED_SPEED` or a coordinate beyond
    :data:`DIVERGED_POSITION`."""
    if not (type(q) is np.ndarray and q.dtype is _FLOAT and q.ndim == 1):     # (a simulator's state is)
        q = np.asarray(q, dtype=float).reshape(-1)
    if not (type(v) is np.ndarray and v.dtype is _FLOAT and v.ndim == 1):
        v = np.asarray(v, dtype=float).reshape(-1)
    finite, speed, reach = state_extent(q, v)        # one compiled pass (the runner checks every cycle)
    return diverged_reason(finite, speed, reach, v)


def diverged_reason(finite: bool, speed: float, reach: float, v: np.ndarray) -> str:
    """:func:`diverged`'s answer from :func:`state_extent`'s of (q, v).

    Args:
        finite: whether q and v are all finite.
        speed: max |v_i| (m/s, rad/s).
        reach: max |q_i| (m, rad).
        v: the velocity (nv), to name the fastest dof.
    """
    if not finite:
        return "simulated state not finite"
    if speed > DIVERGED_SPEED:
        return f"simulated speed {speed:.3g} (m/s or rad/s) beyond {DIVERGED_SPEED:g}, dof {int(np.argmax(np.abs(v)))}"
    if reach > DIVERGED_POSITION:
        return f"simulated coordinate {reach:.3g} beyond {DIVERGED_POSITION:g} (m or rad)"
    return ""


@nb.njit(cache=True)
def state_extent(q, v):
    """(whether q and v are all finite, max |v_i|, max |q_i|; 0 for none): one pass, v first."""
    speed = reach = 0.0
    for x in v:
        if not math.isfinite(x):
            return False, 0.0, 0.0
        speed = max(speed, abs(x))
    for x in q:
        if not math.isfinite(x):
            return False, 0.0, 0.0
        reach = max(reach, abs(x))
    return True, speed, reach


def simulation_diverged(sim, failures_before: int) -> str:
    """Why the simulator ``sim`` diverged in its last step, or "": :func:`diverged` of its
    true state, or a numerical failure it counted (``solver_failures`` above
    ``failures_before``: MuJoCo's reset of a bad position, velocity or acceleration, which
    puts the robot back at its model's reference pose; our simulator's non-finite contact
    impulse)."""
    why = diverged(sim.q, sim.v)
    if not why and getattr(sim, "solver_failures", 0) > failures_before:
        why = "the simulator reported a numerical failure (MuJoCo: a bad state, reset)"
    return why
