"""The per-cycle observers of a run: one small protocol for everything that watches the loop.

A :class:`~wbc.runner.loop.ScenarioRun` holds one list of observers and calls each hook of
each, in list order, at its point of the cycle:

    measure (q, v) -> events -> after_events -> references -> before_solve -> solve
    -> after_solve -> simulator step -> after_step

with one :class:`Cycle` record that the loop fills as the cycle goes (the measured state, then
the solution). The run's own observers come first: the force-task measurement
(:class:`~wbc.interaction.measurement.InteractionRun`), the external-force source and glass
figures (:class:`~wbc.interaction.external_force.ExternalForceRun`), then the user's (a
viewer, ``callback``), then the metrics (:class:`~wbc.runner.metrics.RunMetrics`, which record
the true state last). :meth:`RunObserver.summary` adds to the run's metrics dict.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(slots=True)
class Cycle:
    """What the observers see of control cycle ``k`` at time ``t`` (s).

    ``q``, ``v``: the cycle's one measurement (what the controller gets); ``sim`` the simulator
    (its true state: ``sim.q``, ``sim.v``, ``sim.point_forces``); ``stack`` the controller's
    stack; ``last_sol`` the previous cycle's solution (None at the first); ``sol`` this cycle's
    (from ``after_solve`` on); ``tau_e`` (N·m, nv) the external joint torque the controller is
    told of this cycle, which a ``before_solve`` may set (None: none known); ``switched`` the
    contacts released or touched down so far (names)."""

    k: int
    t: float
    q: np.ndarray
    v: np.ndarray
    sim: Any
    stack: Any
    last_sol: Any = None
    sol: Any = None
    tau_e: np.ndarray | None = None
    switched: frozenset | set = frozenset()


class RunObserver:
    """One observer of a run; every hook is optional (the default does nothing). An observer
    that sets ``stop_reason`` (text) ends the run after the cycle's step, with
    ``stopped`` = {time, by: "observer", reason} in the metrics."""

    stop_reason: str | None = None

    def after_events(self, c: Cycle) -> None:
        """After the cycle's events (the stack or its contacts may have changed)."""

    def before_solve(self, c: Cycle) -> None:
        """Before the solve; may set ``c.tau_e``."""

    def after_solve(self, c: Cycle) -> None:
        """After the solve, before the simulator's step (``c.sol`` is the command)."""

    def after_step(self, c: Cycle) -> None:
        """After the simulator's step (``c.sim`` holds the state the command led to)."""

    def summary(self) -> dict:
        """What the observer adds to the run's metrics."""
        return {}

    def series(self) -> dict:
        """What the observer adds to the run's time series (``metrics["series"]``, a run with
        ``series=True``)."""
        return {}


class InteractionObserver(RunObserver):
    """The force tasks' measurement and interaction figures (:class:`InteractionRun`)."""

    def __init__(self, interaction) -> None:
        self.interaction = interaction

    def before_solve(self, c: Cycle) -> None:
        self.interaction.before_solve(c.q, c.v, c.last_sol)

    def after_step(self, c: Cycle) -> None:
        self.interaction.after_step()

    def summary(self) -> dict:
        return self.interaction.metrics()


class ExternalForceObserver(RunObserver):
    """An interaction scenario's external-force source (the τ̂_e the controller is told) and
    glass figures (:class:`ExternalForceRun`)."""

    def __init__(self, external) -> None:
        self.external = external

    def before_solve(self, c: Cycle) -> None:
        c.tau_e = self.external.before_solve(c.t, c.q, c.v, c.sim)

    def after_step(self, c: Cycle) -> None:
        self.external.after_step(c.sim, c.sol)

    def summary(self) -> dict:
        return self.external.summary()


class CallbackObserver(RunObserver):
    """``callback(t, sim, sol)`` after each simulator step (the viewer's hook)."""

    def __init__(self, callback: Callable) -> None:
        self.callback = callback

    def after_step(self, c: Cycle) -> None:
        self.callback(c.t, c.sim, c.sol)


class MetricsObserver(RunObserver):
    """The run's metrics (:class:`~wbc.runner.metrics.RunMetrics`): what is watched after
    events, the command after the solve, the true state after the step. Its summary is the
    run's core metrics, which :meth:`ScenarioRun.metrics` lays out itself."""

    def __init__(self, metrics) -> None:
        self.metrics = metrics

    def after_events(self, c: Cycle) -> None:
        self.metrics.watch(c.stack, c.switched)

    def after_solve(self, c: Cycle) -> None:
        self.metrics.record_command(c.sol)
        self.metrics.record_singular(c.t, c.sol)

    def after_step(self, c: Cycle) -> None:
        self.metrics.record_state(c.t, c.sim, c.sol, c.stack)


class CollisionObserver(RunObserver):
    """The collision metrics of a stack's :class:`~wbc.tasks.CollisionAvoidance` task
    (:class:`~wbc.collision.monitor.CollisionMonitor`): every monitored pair's distance on the
    simulator's true state after each step, the task's rows in use and at their bound after
    each solve. A pair closer than the safety distance at the start is a warning
    (:class:`~wbc.errors.CollisionWarning`)."""

    def __init__(self, task, q0: np.ndarray) -> None:
        import warnings

        from wbc.collision.monitor import CollisionMonitor
        from wbc.errors import CollisionWarning

        self.task = task
        self.monitor = CollisionMonitor(task.model, task.safety, task.influence)
        for msg in self.monitor.start_warnings(q0):
            warnings.warn(f"task '{task.name}': {msg}", CollisionWarning, stacklevel=4)
        self.in_use = self.binding = 0

    def after_solve(self, c: Cycle) -> None:
        last = self.task.last
        self.in_use = 0 if last is None else len(last[1])
        self.binding = int(np.count_nonzero(self.task.binding_rows(c.sol.x))) if self.in_use else 0

    def after_step(self, c: Cycle) -> None:
        self.monitor.record(c.t + c.sim.dt, c.sim.q, self.in_use, self.binding)
        touching = c.sim.link_contacts() if getattr(c.sim, "link_geom_names", None) else None
        if touching is not None:
            self.mujoco_checked = True
            if touching:
                self.link_contact_cycles += 1
                if self.first_contact is None:
                    self.first_contact = {"time": c.t + c.sim.dt, "contacts": [list(x) for x in touching[:5]]}

    mujoco_checked = False
    link_contact_cycles = 0
    first_contact: dict | None = None

    def summary(self) -> dict:
        out = self.monitor.summary()
        if self.mujoco_checked:
            out.update(mujoco_link_contacts=self.link_contact_cycles, mujoco_link_contact_first=self.first_contact)
        return out
