"""A live run a person can act in: commands from a page, applied at the start of a control cycle,
and snapshots of the state published for a drawing process.

Two threads meet here and only here:

- the page's thread (a browser view's server) calls :meth:`Mailbox.post`; commands are kept per
  key, the last one wins (two tabs dragging the same target: the later drag; a disconnect
  mid-run: nothing is posted, nothing changes);
- the control loop (:func:`run_live`) takes the whole mailbox at the start of a cycle
  (:meth:`Mailbox.take`, one lock, a dict swap) and applies it (:func:`apply_commands`) before
  the cycle's events, references and solve, so a target posted before cycle k is the one
  cycle k tracks. After each ``1/fps`` s of simulated time it publishes a :class:`Snapshot`
  (copies, a few µs) through ``publish``; it never waits on the page or its transport.

Commands (key → value):

- ``("target", task)`` → a 3-vector (m: a CoM, or a frame's position, its rotation kept) or a
  4×4 pose (a frame, m): the task's target (its trajectory, if any, is dropped: the page drives
  it from now on);
- ``("kp", task)``, ``("weight", task)`` → a number, clamped to :func:`gain_range` /
  :func:`weight_range`;
- ``("enabled", task)`` → bool (a disabled task leaves the stack and comes back to the level
  it had);
- ``("level", task)`` → int (:meth:`wbc.Stack.move`; the lowest level + 1 makes a new one);
- ``("push", frame)`` → (force (N, world, 3), duration (s)), from the cycle's time;
- ``"pause"`` → bool; ``"step"`` → a count of cycles to run while paused; ``"speed"`` → × real time;
  ``"stop"`` → True: end the run after this cycle (its metrics as usual).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.blas import blas_threads
from wbc.runner.loop import ScenarioRun
from wbc.runner.options import RunOptions
from wbc.scenario.loader import Scenario
from wbc.tasks.com import CoM
from wbc.tasks.contact import Contact
from wbc.tasks.frame import Frame
from wbc.tasks.tuning import adjustable, gain_range, weight_range

SPEED_RANGE = (0.05, 4.0)       # × real time


class Mailbox:
    """Thread-safe commands from a page to the control loop: per key, the last posted wins.
    ``feed``: called with the mailbox at the start of each :meth:`take` (a page in another
    process: :meth:`wbc.viz.live.LiveView.drain` posts what arrived from it)."""

    def __init__(self, feed: Callable[[Mailbox], None] | None = None) -> None:
        self.feed = feed
        self._lock = threading.Lock()
        self._box: dict = {}
        self.posted = 0             # commands posted (the page's count, for tests and logs)

    def post(self, key, value) -> None:
        """Post a command (module docstring); a step adds to the steps not yet taken.

        Args:
            key: the command's key (``"pause"``, ``("kp", "com")``, ...).
            value: its value.
        """
        with self._lock:
            if key == "step":
                value = int(value) + int(self._box.get("step", 0))
            self._box[key] = value
            self.posted += 1

    def take(self) -> dict:
        """Every command posted since the last take (and empty the box)."""
        if self.feed is not None:
            self.feed(self)
        with self._lock:
            box, self._box = self._box, {}
        return box


@dataclass
class Snapshot:
    """The state a drawing thread draws: copies, never the loop's own arrays.

    ``t`` (s), ``q`` (the simulator's true configuration), ``points`` (m, world) and ``forces``
    (N, world) of the contact points, ``pushes`` [(frame, force N)] acting now, ``targets``
    {task: 3-vector or 4×4 pose}, ``sol`` the cycle's :class:`wbc.Solution` (immutable once
    returned), ``normal`` {contact task: normal force N}, ``levels`` [[task names]] of the stack
    now, ``disabled`` [task names], ``paused``, ``speed``, ``rtf`` (real-time factor so far),
    ``done`` (the run has ended), ``overlays`` the run's overlays (``extras`` of :func:`run_live`)."""

    t: float
    q: np.ndarray
    points: np.ndarray
    forces: np.ndarray
    pushes: list
    targets: dict
    sol: Any
    normal: dict
    levels: list
    disabled: list = field(default_factory=list)
    paused: bool = False
    speed: float = 1.0
    rtf: float = 0.0
    done: bool = False
    overlays: dict = field(default_factory=dict)


class LiveControl:
    """Applies a :class:`Mailbox`'s commands to a :class:`~wbc.runner.loop.ScenarioRun` (as its
    ``RunOptions.mailbox``: called at the start of each cycle) and keeps the pause, step and
    speed state that :func:`run_live` paces by."""

    def __init__(self, mailbox: Mailbox, speed: float = 1.0) -> None:
        self.mailbox = mailbox
        self.paused = False
        self.steps = 0
        self.speed = float(np.clip(speed, *SPEED_RANGE))
        self.disabled: dict[str, tuple[Any, int]] = {}      # name -> (task, its level)
        self.applied = 0
        self.stop = False
        self.kp0: dict[str, float] = {}

    def poll(self) -> dict:
        """Take the pause/step/speed commands now (the rest stays for :meth:`apply`)."""
        box = self.mailbox.take()
        if "pause" in box:
            self.paused = bool(box.pop("pause"))
        if "step" in box:
            self.steps += max(0, int(box.pop("step")))
        if box.pop("stop", False):
            self.stop = True
        if "speed" in box:
            self.speed = float(np.clip(float(box.pop("speed")), *SPEED_RANGE))
        self._pending = {**getattr(self, "_pending", {}), **box}
        return box

    def apply(self, run: ScenarioRun, t: float, measured) -> bool:
        """Apply the posted commands to ``run`` at cycle time ``t`` (s); ``measured``: the cycle's
        (q, v). True when the stack changed (the run then refreshes its observers)."""
        self.poll()
        box, self._pending = self._pending, {}
        changed = False
        stack = run.stack
        for key, value in box.items():
            kind, name = key
            self.applied += 1
            if kind == "push":
                force, duration = value
                run.sim.push(name, np.asarray(force, float), t, float(duration))
                continue
            task: Any = stack[name] if name in stack else (self.disabled[name][0] if name in self.disabled else None)
            if task is None:
                continue
            if kind == "target":
                run.refs.pop(name, None)
                value = np.asarray(value, float)
                if isinstance(task, CoM):
                    task.set_reference(value)
                elif value.shape == (3,):       # a position: the target keeps its rotation
                    rotation = task.target.rotation if task.target is not None else np.eye(3)
                    task.set_reference(pin.SE3(rotation, value))
                else:
                    task.set_reference(pin.SE3(value))
            elif kind == "kp" and adjustable(task):
                kp0 = self.kp0.setdefault(name, float(task.kp))
                critical = np.allclose(task.kd, 2.0 * np.sqrt(task.kp))
                kp = float(np.clip(float(value), *gain_range(task, kp0)))
                task.set_gains(kp, None if critical else task.kd)
            elif kind == "weight":
                task.weight = float(np.clip(float(value), *weight_range(task)))
            elif kind == "enabled":
                if not value and name in stack and not isinstance(task, Contact):
                    self.disabled[name] = (task, stack.level_of(name))
                    stack.remove(name)
                    changed = True
                elif value and name in self.disabled:
                    task, level = self.disabled.pop(name)
                    stack.add(task, min(level, len(stack.levels)))
                    changed = True
            elif kind == "level" and name in stack:
                stack.move(name, max(0, int(value)))
                changed = True
        return changed


def snapshot(run: ScenarioRun, t: float, live: LiveControl | None = None, done: bool = False,
             extras: Callable[[ScenarioRun, float], dict] | None = None) -> Snapshot:
    """The run's state now, as copies (:class:`Snapshot`); ``extras(run, t)``: its overlays."""
    sim, stack = run.sim, run.stack
    forces = np.array(sim.point_forces, dtype=float)
    targets: dict[str, np.ndarray] = {}
    task: Any
    for task in stack:
        if isinstance(task, CoM) and task.target is not None:
            targets[task.name] = np.array(task.target, dtype=np.float64)
        elif isinstance(task, Frame) and task.target is not None:
            targets[task.name] = task.target.homogeneous.copy()
    normal = {c.name: float(forces[idx, 2].sum()) if idx else 0.0 for c, idx in
              ((c, run.contact_points.get(c.name, [])) for c in run.contacts)}
    pushes = [(p.frame, np.array(p.force, dtype=float)) for p in sim.pushes if p.active(t)]
    return Snapshot(t=t, q=np.array(sim.q, dtype=float), points=np.array(sim.point_positions(), dtype=float),
                    forces=forces, pushes=pushes, targets=targets, sol=run.last_sol, normal=normal,
                    levels=[[task.name for task in lvl] for lvl in stack.levels],
                    disabled=sorted(live.disabled) if live else [], paused=bool(live and live.paused),
                    speed=live.speed if live else 1.0, rtf=run.real_time_factor(), done=done,
                    overlays=extras(run, t) if extras is not None else {})


def run_live(sc: Scenario, options: RunOptions, publish: Callable[[Snapshot], None], mailbox: Mailbox | None = None,
             fps: float = 30.0, speed: float = 1.0, realtime: bool = True,
             extras: Callable[[ScenarioRun, float], dict] | None = None) -> dict:
    """Run ``sc`` paced to ``speed`` × real time (``realtime``), applying ``mailbox``'s commands at
    the start of each cycle and publishing a :class:`Snapshot` every ``1/fps`` s of simulated time
    (and while paused, at ``fps`` per wall second); returns the metrics dict.

    Args:
        sc: the scenario.
        options: the run's options (its ``mailbox`` is set here).
        publish: called with each snapshot, in the control thread: must only store it.
        mailbox: the page's commands (None: a run nobody acts in).
        fps: snapshots per simulated second.
        speed: initial playback speed, × real time.
        realtime: pace the loop (False: as fast as it goes, pause and step still hold).
        extras: ``extras(run, t)`` gives each snapshot's ``overlays``.
    """
    import dataclasses

    live = LiveControl(mailbox or Mailbox(), speed)
    r = ScenarioRun(sc, dataclasses.replace(options, mailbox=live))
    every = max(1, round(1.0 / (fps * sc.dt)))
    wall0, sim0 = time.perf_counter(), 0.0        # pacing anchor: sim time sim0 at wall0
    k = 0
    with blas_threads(r.options.blas_threads):      # as run(): one OpenBLAS thread by default
        while k < r.n:
            live.poll()
            if live.stop:
                break
            if live.paused and not live.steps:
                paused_at = time.perf_counter()
                publish(snapshot(r, k * sc.dt, live, extras=extras))
                while live.paused and not live.steps and not live.stop:
                    time.sleep(1.0 / fps)
                    live.poll()
                r.exclude_wall_time(time.perf_counter() - paused_at)
                wall0, sim0 = time.perf_counter(), k * sc.dt
                continue                        # stopped, stepped or resumed: look again
            if live.steps:
                live.steps -= 1
            speed_before = live.speed
            ok = r.cycle(k)
            k += 1
            if k % every == 0 or not ok:
                publish(snapshot(r, k * sc.dt, live, extras=extras))
            if not ok:
                break
            if live.speed != speed_before:
                wall0, sim0 = time.perf_counter(), k * sc.dt
            if realtime:
                lag = (k * sc.dt - sim0) / live.speed - (time.perf_counter() - wall0)
                if lag > 2e-3:          # sleep in ≥ 2 ms slices: the OS's timer does not do better
                    time.sleep(lag)
    metrics = r.metrics()
    publish(snapshot(r, k * sc.dt, live, done=True, extras=extras))
    return metrics
