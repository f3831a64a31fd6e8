"""A scenario's timed ``events:`` (``release``, ``touchdown``, ``add``, ``remove``), checked
against the stack as it will be when each one happens.

    events:
      - {time: 1.5, add: {type: frame, frame: right_foot, name: right_swing}, level: 1,
         trajectory: {type: waypoints, ...}}
      - {time: 1.5, release: right_foot_contact, duration: 0.2}
      - {time: 2.6, touchdown: {type: contact, contact: right_foot}, level: 0, duration: 0.2}
      - {time: 2.85, remove: right_swing}

Keys per kind: ``time`` (s, in [0, duration)) always; ``duration`` (s, > 0: the force ramp)
for release and touchdown; ``level`` (an integer >= 0) for add and touchdown; ``trajectory``
for an added com or frame task (offsets from its ``target`` if the ``add`` gives one, else from
its value when added; :mod:`wbc.trajectories.position`). :func:`check_timeline` replays the events on the task names
cycle by cycle, as the runner and the controller will apply them (a released contact leaves
the stack when its ramp ends; an empty level is dropped), and refuses what would fail or be
ignored mid-run: a name that is not in the stack then, or is twice; removing a task whose
force ramp is under way; a touch-down below the last level + 1; two contact tasks on one
contact surface; a contact removed while a contact_wrench or force task still refers to it.
"""

from __future__ import annotations

import math
import sys
from typing import Any

from wbc.errors import ConfigError, WbcError, placed
from wbc.robot.gains import apply_robot_gains
from wbc.scenario.build_tasks import build_task
from wbc.scenario.sections import MAX_DURATION
from wbc.tasks.com import CoM
from wbc.tasks.contact import Contact
from wbc.tasks.contact_wrench import ContactWrench
from wbc.tasks.force import Force
from wbc.tasks.frame import Frame
from wbc.trajectories.position import build_task_trajectory
from wbc.validation.schema import integer, mapping, number, sequence, show, suggest, text

KINDS = ("release", "add", "touchdown", "remove")
_KEYS = {"release": {"time", "release", "duration"}, "remove": {"time", "remove"},
         "touchdown": {"time", "touchdown", "level", "duration"}, "add": {"time", "add", "level", "trajectory"}}
MAX_LEVEL = 1000
#: task types that act on a contact task's force variables (they name it as ``contact``)
_ON_FORCES = (ContactWrench, Force)


def build_events(spec: Any, robot, stack, dt: float, duration: float) -> list[dict]:
    """``events:`` -> the runner's event dicts (``time``, ``kind``, ``duration``, and ``name``
    or ``task``, ``level``, ``trajectory``), sorted by time and checked by
    :func:`check_timeline` against ``stack`` (the scenario's tasks, bound to ``robot``)."""
    events = []
    for i, ev in enumerate(sequence(spec if spec is not None else [], "events", what="a list of events")):
        where = f"events[{i}]"
        ev = mapping(ev, where, what="an event mapping (time and one of release, add, touchdown, remove)")
        kinds = [k for k in KINDS if k in ev]
        if len(kinds) != 1:
            raise ConfigError(f"must have exactly one of {list(KINDS)}, got {kinds or 'none'}", key=where)
        kind = kinds[0]
        mapping(ev, where, allowed=_KEYS[kind], required=("time",))
        e: dict = {"time": number(ev["time"], f"{where}.time", ge=0, lt=duration,
                                  unit=f"s; inside the run [0, {duration:g})"),
                   "kind": kind, "index": i,
                   "duration": number(ev.get("duration", 0.2), f"{where}.duration", gt=0, le=MAX_DURATION, unit="s")}
        if kind in ("release", "remove"):
            e["name"] = text(ev[kind], f"{where}.{kind}", what="the name of a task in the stack")
        else:
            body = ev[kind]
            if kind == "touchdown":
                body = mapping(body, f"{where}.touchdown", what="a contact task mapping (type: contact)")
                if body.get("type") != "contact":
                    raise ConfigError("must be contact (a touchdown adds a contact task), got "
                                      f"{show(body.get('type'))}", key=f"{where}.touchdown.type")
            task = build_task(body, f"{where}.{kind}")
            try:
                task.bind(robot)
                apply_robot_gains(task, body if isinstance(body, dict) else {}, robot)   # wbc.robot.gains precedence
            except WbcError as exc:
                raise placed(exc, f"{where}.{kind}", cls=ConfigError) from exc
            if kind == "add" and isinstance(task, (CoM, Frame)) and isinstance(body, dict) and "target" in body:
                # the runner starts the task (and a relative trajectory) there, not where the robot is
                e["target"] = task.target.copy() if isinstance(task, CoM) else body["target"]  # type: ignore[union-attr]  # a com built from a body with a target has one; a frame's: as given
            e["task"] = task
            e["level"] = integer(ev.get("level", 0), f"{where}.level", ge=0, le=MAX_LEVEL)
            if "trajectory" in ev:
                e["trajectory"] = build_task_trajectory(task, ev["trajectory"], f"{where}.trajectory", dt)
        events.append(e)
    events.sort(key=lambda e: e["time"])
    check_timeline(events, stack, dt)
    for e in events:
        del e["index"]
    return events


def _cycle(time: float, dt: float) -> int:
    """The control cycle k at which the runner applies an event at ``time``: the first k
    with time <= k dt + 1e-9 (its own test, in floating point)."""
    k = max(0, math.ceil((time - 1e-9) / dt))
    while k > 0 and time <= (k - 1) * dt + 1e-9:
        k -= 1
    while time > k * dt + 1e-9:
        k += 1
    return k


class _Timeline:
    """The stack's task names level by level, and the force ramps under way."""

    def __init__(self, stack) -> None:
        self.levels = [list(lvl) for lvl in stack.levels]
        self.ramps: dict[str, tuple[int, bool, str]] = {}    # name -> (last cycle, removes it, event key)

    def tasks(self) -> dict:
        return {t.name: t for lvl in self.levels for t in lvl}

    def drop(self, name: str, key: str, when: str) -> None:
        tasks = self.tasks()
        needs = [t for t in tasks.values() if isinstance(t, _ON_FORCES) and t.contact == name]
        if needs:
            raise ConfigError(f"removes contact task '{name}' {when} while {needs[0].kind} task '{needs[0].name}' "
                              "still acts on its force; remove that task first", key=key)
        for lvl in self.levels:
            lvl[:] = [t for t in lvl if t.name != name]
        self.levels = [lvl for lvl in self.levels if lvl]

    def advance(self, cycle: int, dt: float) -> None:
        """Finish the ramps whose last cycle is before ``cycle`` (released contacts leave)."""
        for name, (last, removes, key) in sorted(self.ramps.items(), key=lambda kv: kv[1][0]):
            if last < cycle:
                del self.ramps[name]
                if removes:
                    self.drop(name, key, f"at the end of its release (t = {(last + 1) * dt:g} s)")

    def insert(self, task, level: int, key: str, when: str) -> None:
        tasks = self.tasks()
        if task.name in tasks:
            raise ConfigError(f"adds a task named '{task.name}' {when}, but the stack has one then (names must be "
                              "unique: give it another name)", key=key)
        if isinstance(task, Contact):
            same = [t.name for t in tasks.values() if isinstance(t, Contact) and t.contact == task.contact]
            if same:
                raise ConfigError(f"contact '{task.contact}' is already held by task '{same[0]}' {when}", key=key)
        if isinstance(task, _ON_FORCES):
            contact = tasks.get(task.contact)
            if not isinstance(contact, Contact) or (task.contact in self.ramps and self.ramps[task.contact][1]):
                there = sorted(n for n, t in tasks.items() if isinstance(t, Contact))
                raise ConfigError(f"{task.kind} task '{task.name}' needs contact task '{task.contact}' in the "
                                  f"stack {when}; there: {there}", key=key)
        if level == len(self.levels):
            self.levels.append([])
        self.levels[level].append(task)


def check_timeline(events: list[dict], stack, dt: float) -> None:
    """Replay ``events`` (sorted by time) on the names of ``stack``; see the module docstring."""
    line = _Timeline(stack)
    for e in events:
        where, c = f"events[{e['index']}]", _cycle(e["time"], dt)
        when = f"at t = {e['time']:g} s"
        line.advance(c, dt)
        tasks = line.tasks()
        ramp_cycles = max(1, int(round(e["duration"] / dt)))
        if e["kind"] in ("release", "remove"):
            name, key = e["name"], f"{where}.{e['kind']}"
            if name not in tasks:
                raise ConfigError(f"no task named '{name}' in the stack {when}{suggest(name, tasks)}; tasks then: "
                                  f"{sorted(tasks)}", key=key)
            if name in line.ramps:
                last, removes, src = line.ramps[name]
                doing = "released" if removes else "touching down"
                if e["kind"] == "remove" or removes:
                    raise ConfigError(f"task '{name}' is being {doing} ({src}) until t = {(last + 1) * dt:g} s; "
                                      f"{e['kind']} it after that", key=key)
            if e["kind"] == "release":
                if not isinstance(tasks[name], Contact):
                    raise ConfigError(f"'{name}' is a {tasks[name].kind} task; release takes a contact task "
                                      "(use remove for other tasks)", key=key)
                line.ramps[name] = (c + ramp_cycles - 1, True, where)
            else:
                line.drop(name, key, when)
        else:
            task, key = e["task"], f"{where}.{e['kind']}"
            level = e["level"]
            if e["kind"] == "touchdown" and level > len(line.levels):
                raise ConfigError(f"must be in [0, {len(line.levels)}] {when} (the stack has {len(line.levels)} "
                                  f"levels then; {len(line.levels)} adds a new lowest one), got {level}",
                                  key=f"{where}.level")
            line.insert(task, min(level, len(line.levels)), key, when)
            if e["kind"] == "touchdown":
                line.ramps[task.name] = (c + ramp_cycles - 1, False, where)
    line.advance(sys.maxsize, dt)       # the ramps still under way end too (in this run, or a longer one)
