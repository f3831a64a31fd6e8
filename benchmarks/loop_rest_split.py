"""What the closed loop's "rest" is (``closed_loop_split.py``: the cycle less the pieces it times, #26):
talos_balance (hqp, 2 s, the own simulator by default) with :meth:`ScenarioRun.cycle`'s default path
(no mailbox command, no velocity mode) run as a copy that reads ``perf_counter_ns`` between its pieces,
medians (µs) from the 51st cycle on. ``perf_counter_ns`` costs ~0.05-0.4 µs a read (vDSO); the
``thread_time_ns`` of ``closed_loop_split.py`` is a system call (~1-4 µs a read in this VM under load),
and its wrappers' own cost outside the timed calls lands in its "rest".

    PYTHONPATH=. python benchmarks/loop_rest_split.py [pinocchio|mujoco]

The copy follows ``ScenarioRun.cycle`` as of the thirtieth pass (branch loop8); a changed cycle needs
the copy changed too.
"""

from __future__ import annotations

import sys
import time
import warnings
from typing import Any

import numpy as np

from wbc.blas import blas_threads
from wbc.runner.loop import (
    _FLOAT,
    FALL_TILT,
    CoM,
    Cycle,
    ScenarioRun,
    Sinusoid,
    SinusoidCycles,
    _apply_event,
    diverged_reason,
    fallen,
    frame_reference,
    simulation_diverged,
    step_checks,
)
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config

TIMES: dict[str, list[int]] = {}


def _note(key: str, t0: int) -> int:
    t1 = time.perf_counter_ns()
    TIMES.setdefault(key, []).append(t1 - t0)
    return t1


class TimedRun(ScenarioRun):
    """A run whose cycle is the default path of ``ScenarioRun.cycle`` with clock reads between its pieces."""

    def cycle(self, k: int) -> bool:     # noqa: C901 (the cycle's own branches, as in loop.py)
        t = t_cycle = time.perf_counter_ns()
        sc, stack, sim, ctrl = self.sc, self.stack, self.sim, self.ctrl
        now = k * sc.dt
        pending = self.pending
        q, v = sim.measure()
        t = _note("sim.measure", t)
        c = Cycle(k, now, q, v, sim, stack, self.last_sol, None, None, self.switched)
        t = _note("Cycle(...)", t)
        observers = self.observers
        mailbox = self.options.mailbox
        commanded = mailbox is not None and mailbox.apply(self, now, (q, v))
        if k == 0 or commanded or (pending and pending[0]["time"] <= now + 1e-9):
            while pending and pending[0]["time"] <= now + 1e-9:
                _apply_event(pending.pop(0), ctrl, self.robot, (q, v), self.refs, self.start, now, self.switched)
            for o in observers:
                o.after_events(c)
        named = self._named
        if named[0] != stack.version:
            named = self._named = (stack.version, {})
        t = _note("mailbox, events, named", t)
        for tname, (traj, absolute, t0) in self.refs.items():
            task: Any = named[1].get(tname)
            if task is None:
                try:
                    task = named[1][tname] = stack[tname]
                except KeyError:
                    continue
            if not isinstance(task, CoM):
                task.set_reference(*frame_reference(traj, absolute, self.start[tname], now - t0))
                t = _note("frame reference", t)
            elif type(traj) is Sinusoid:
                cycles = self._cycles.get(tname)
                if cycles is None or cycles.traj is not traj or cycles.t0 != t0:
                    cycles = self._cycles[tname] = SinusoidCycles(traj, sc.dt, t0)
                values = cycles.values(k, None if absolute else self.start[tname])
                t = _note("trajectory sample", t)
                task.set_reference_values(*values)
                t = _note("set_reference (with start + x)", t)
            else:
                x, dx, ddx = traj.sample(now - t0)
                t = _note("trajectory sample", t)
                task.set_reference(x if absolute else self.start[tname] + x, dx, ddx)
                t = _note("set_reference (with start + x)", t)
        for o in observers:
            o.before_solve(c)
        t = _note("before_solve", t)
        t0 = time.perf_counter()
        sol = self.last_sol = c.sol = ctrl.solve(q, v, c.tau_e)
        self.cycle_times[k] = time.perf_counter() - t0
        t = _note("controller.solve", t)
        if k == 0:
            self.notice.stop()
            self.t_wall, self.k_wall = time.perf_counter(), 1
        if sol.fault in ("solve_failures", "solver_errors"):
            self.failures += 1
        if sol.status == "stopped":
            return False
        t = _note("solution checks", t)
        for o in observers:
            o.after_solve(c)
        t = _note("after_solve (record_command, record_singular)", t)
        sim.step(sol.tau_full)
        t = _note("sim.step", t)
        qs, vs = sim.q, sim.v
        if not (type(qs) is np.ndarray is type(vs) and qs.dtype == _FLOAT == vs.dtype and qs.ndim == 1 == vs.ndim):
            raise SystemExit("loop_rest_split: a state the compiled checks do not take")
        t = _note("state type test", t)
        finite, speed, reach, fell = step_checks(qs, vs, self.z_fall, FALL_TILT, self.base_z0 is not None)
        t = _note("step_checks", t)
        why = diverged_reason(finite, speed, reach, vs)
        if not why and getattr(sim, "solver_failures", 0) > self.sim_failures:
            why = simulation_diverged(sim, self.sim_failures)
        if why:
            return False
        t = _note("diverged_reason", t)
        for o in observers:
            o.after_step(c)
        t = _note("after_step (record_state)", t)
        if any(o.stop_reason for o in observers):
            return False
        if fell is None and self.base_z0 is not None:
            fell = fallen(sim.q, self.base_z0)
        if fell:
            self.fell = True
            return False
        _note("stop reasons, fall", t)
        _note("whole cycle", t_cycle)
        return True


def main(simulator: str = "pinocchio") -> None:
    warnings.simplefilter("ignore")
    r = TimedRun(load_config(SCENARIOS_DIR / "talos_balance.yaml"), solver="hqp", duration=2.0, simulator=simulator)
    with blas_threads(r.options.blas_threads):
        for k in range(r.n):
            if not r.cycle(k):
                break
    med = {key: float(np.median(x[50:])) / 1e3 for key, x in TIMES.items()}
    timed = ("sim.measure", "controller.solve", "sim.step", "step_checks", "after_solve (record_command, "
             "record_singular)", "after_step (record_state)", "set_reference (with start + x)",
             "frame reference")
    for key, m in med.items():
        print(f"{key:48s} {m:7.2f} µs")
    rest = sum(m for key, m in med.items() if key not in timed and key != "whole cycle")
    print(f"{'rest (what closed_loop_split does not time)':48s} {rest:7.2f} µs")


if __name__ == "__main__":
    main(*sys.argv[1:2])
