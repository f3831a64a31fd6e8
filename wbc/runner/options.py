"""The settings of one closed-loop run, in one record from the CLI down to the simulator.

``wbc run`` builds a :class:`RunOptions` from its flags, :func:`wbc.runner.loop.run` and
:class:`~wbc.runner.loop.ScenarioRun` take it (or its fields as keywords), and the run hands
the controller and the simulator their parts of it. A field left None takes the scenario's
value (its ``solver:``, ``simulator:``, ``duration:``, ``joint_dynamics:``, ``faults:``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from wbc.controller.faults import FaultPolicy


@dataclass(frozen=True, slots=True)
class RunOptions:
    """How to run a scenario.

    Attributes:
        solver: priority solver name (``hqp``, ``projection``, ``weighted``); None: the scenario's.
        backend: QP back-end name or :class:`~wbc.solvers.backends.Backend`; None: the scenario's (daqp).
        duration: simulated time (s), at least one control period; None: the scenario's.
        simulator: physics back-end (:data:`wbc.sim.backends.SIMULATORS`); None: the scenario's.
        joint_dynamics: the URDF's joint damping and friction in the simulator; None: the scenario's.
        faults: the controller's fault policy; None: the scenario's ``faults:`` with stale-state
            detection on (the simulator's state always moves).
        series: also return the run's time series under ``metrics["series"]``.
        progress: print the progress line (and the compile notice) to stderr.
        observers: extra per-cycle observers (:class:`~wbc.runner.observers.RunObserver`), called
            after the run's own, in order (a viewer, a recorder).
        callback: ``callback(t, sim, sol)`` after each simulator step (wrapped as an observer).
        model_perturbation: ``f(model)`` changes, in place, a copy of the pinocchio model the
            simulator simulates (the controller keeps the nominal one): model error.
        wrap_simulator: ``f(sim)`` -> the object the loop drives in place of the simulator,
            with the same :class:`~wbc.sim.backends.PhysicsSimulator` members (the bench's timer).
        mode: ``"torque"`` or ``"velocity"`` (position-controlled actuators, :mod:`wbc.controller.velocity`);
            None: the scenario's ``mode``.
        mailbox: an object whose ``apply(run, t, (q, v))`` the loop calls at the start of each
            cycle, after measuring (commands from a page, :mod:`wbc.runner.interactive`); it
            returns True when it changed the stack.
        blas_threads: the OpenBLAS thread count during :func:`~wbc.runner.loop.run`'s loop
            (:func:`wbc.blas.blas_threads`; each library's own count is restored after): 1 by
            default, the cascade's matrices being far too small for BLAS threads to pay (they
            spin and take the other cores); None: leave it as the environment set it.
    """

    solver: str | None = None
    backend: Any = None
    duration: float | None = None
    simulator: str | None = None
    joint_dynamics: bool | None = None
    faults: FaultPolicy | None = None
    series: bool = False
    progress: bool = False
    observers: Sequence = field(default_factory=tuple)
    callback: Callable | None = None
    model_perturbation: Callable | None = None
    wrap_simulator: Callable | None = None
    mode: str | None = None
    mailbox: Any = None
    blas_threads: int | None = 1

    @classmethod
    def of(cls, options: RunOptions | None, settings: dict) -> RunOptions:
        """``options`` (default all None) with the keyword ``settings`` put in; a key that is
        not a field is a TypeError naming it and the fields."""
        base = options if options is not None else cls()
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(settings) - names)
        if unknown:
            raise TypeError(f"unknown run setting(s) {unknown}: expected {sorted(names)}")
        return dataclasses.replace(base, **settings) if settings else base
