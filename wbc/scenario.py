"""Scenario YAML (``tasks/*.yaml``) -> a ready-to-run :class:`Scenario`.

    name: talos_balance
    robot: talos                       # bundled name or path to a robot YAML
    solver: {type: hqp, backend: daqp} # or projection / weighted
    control: {dt: 0.001, substeps: 1}
    duration: 10.0
    environment: [{type: ground, mu: 0.8}, {type: box, center: [..], size: [..], mu: 0.5}]
    stack:                             # levels, each a list of tasks
      - [{type: joint_limits}, {type: contact, contact: left_foot}, ...]
      - [{type: com, kp: 100, trajectory: {type: sinusoid, amplitude: [0, 0.05, 0], frequency: 0.5}}]
    pushes: [{frame: torso, force: [60, 0, 0], start: 2.0, duration: 0.1}]
    sensing: {noise_q: 0.0, noise_v: 0.0, latency_steps: 0}

A task may carry ``offset`` (added to its value at the start) or ``trajectory``
(:mod:`wbc.trajectories`, an offset from the start value unless ``absolute``).
Errors name the file, the key path and what was expected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .config import build_task, read_yaml
from .examples import scenario_path
from .errors import ConfigError, WbcError
from .robots import load_robot
from .sim.environment import Box, ground, incline
from .stack import Stack
from .trajectories import build_trajectory

_TOP = {"name", "robot", "solver", "control", "duration", "environment", "stack", "pushes", "sensing",
        "description", "acceptance", "events"}
_EVENT_KINDS = ("release", "add", "touchdown", "remove")
_SOLVER_KEYS = {"type", "backend", "weighting", "level_weight"}


@dataclass
class Scenario:
    name: str
    robot: object
    stack: Stack
    solver: dict
    dt: float
    substeps: int
    duration: float
    environment: list
    pushes: list[dict]
    sensing: dict
    references: dict[str, tuple] = field(default_factory=dict)   # task name -> (trajectory, absolute)
    offsets: dict[str, np.ndarray] = field(default_factory=dict)
    acceptance: dict = field(default_factory=dict)
    events: list[dict] = field(default_factory=list)
    source: Path | None = None


def _number(src, key, val, positive=True):
    if not isinstance(val, (int, float)) or (positive and val <= 0):
        raise ConfigError(f"{src}: {key}: expected a {'positive ' if positive else ''}number, got {val!r}")
    return float(val)


def _environment(src, spec) -> list:
    if spec is None:
        return [ground()]
    if not isinstance(spec, list):
        raise ConfigError(f"{src}: environment: expected a list of shapes")
    out = []
    for i, s in enumerate(spec):
        where = f"{src}: environment[{i}]"
        if not isinstance(s, dict) or s.get("type") not in ("ground", "box", "incline"):
            raise ConfigError(f"{where}.type: expected ground, box or incline")
        mu = _number(src, f"environment[{i}].mu", s.get("mu", 0.8))
        if s["type"] == "ground":
            out.append(ground(float(s.get("height", 0.0)), mu))
        elif s["type"] == "incline":
            out.append(incline(float(s.get("angle", 0.0)), mu))
        else:
            try:
                out.append(Box(np.asarray(s["center"], float).reshape(3), np.asarray(s["size"], float).reshape(3), mu,
                               s.get("name", f"box{i}")))
            except (KeyError, ValueError) as exc:
                raise ConfigError(f"{where}: a box needs center: [x, y, z] and size: [sx, sy, sz] (m)") from exc
    return out


def load_config(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML (see the module docstring): a path, or the name
    of a bundled scenario (``"talos_balance"``, see :mod:`wbc.examples`)."""
    src = scenario_path(path)
    cfg = read_yaml(src)
    for key in cfg:
        if key not in _TOP:
            raise ConfigError(f"{src}: {key}: unknown key; expected one of {sorted(_TOP)}")
    for key in ("robot", "stack"):
        if key not in cfg:
            raise ConfigError(f"{src}: {key}: missing (required)")
    try:
        robot = load_robot(cfg["robot"] if not str(cfg["robot"]).endswith((".yaml", ".yml"))
                           else (src.parent / cfg["robot"]))
    except WbcError as exc:
        raise ConfigError(f"{src}: robot: {exc}") from exc

    solver = dict(cfg.get("solver") or {"type": "hqp"})
    for key in solver:
        if key not in _SOLVER_KEYS:
            raise ConfigError(f"{src}: solver.{key}: unknown key; expected one of {sorted(_SOLVER_KEYS)}")
    if solver.get("type", "hqp") not in ("hqp", "projection", "weighted"):
        raise ConfigError(f"{src}: solver.type: expected hqp, projection or weighted, got {solver.get('type')!r}")
    control = cfg.get("control") or {}
    dt = _number(src, "control.dt", control.get("dt", 1e-3))
    substeps = int(_number(src, "control.substeps", control.get("substeps", 1)))

    levels = cfg["stack"]
    if not isinstance(levels, list) or not levels:
        raise ConfigError(f"{src}: stack: expected a non-empty list of levels (each a list of tasks)")
    built, refs, offsets = [], {}, {}
    for k, level in enumerate(levels):
        if not isinstance(level, list) or not level:
            raise ConfigError(f"{src}: stack[{k}]: expected a non-empty list of tasks")
        tasks = []
        for i, spec in enumerate(level):
            where = f"{src}: stack[{k}][{i}]"
            spec = dict(spec) if isinstance(spec, dict) else spec
            traj = spec.pop("trajectory", None) if isinstance(spec, dict) else None
            offset = spec.pop("offset", None) if isinstance(spec, dict) else None
            task = build_task(spec, where)
            if traj is not None or offset is not None:
                if task.kind not in ("com", "frame"):
                    raise ConfigError(f"{where}: trajectory/offset apply to com and frame tasks, not '{task.kind}'")
                if offset is not None:
                    off = np.asarray(offset, float)
                    if off.shape != (3,):
                        raise ConfigError(f"{where}.offset: expected [x, y, z] (m), got {offset!r}")
                    offsets[task.name] = off
                if traj is not None:
                    absolute = bool(traj.get("absolute", False)) if isinstance(traj, dict) else False
                    refs[task.name] = (build_trajectory(traj, 3, f"{where}.trajectory"), absolute)
            tasks.append(task)
        built.append(tasks)
    try:
        stack = Stack(built)
        for t in stack:
            t.bind(robot)
    except WbcError as exc:
        raise ConfigError(f"{src}: stack: {exc}") from exc

    pushes = []
    for i, p in enumerate(cfg.get("pushes") or []):
        where = f"pushes[{i}]"
        if not isinstance(p, dict) or not {"frame", "force", "start", "duration"} <= set(p):
            raise ConfigError(f"{src}: {where}: expected frame, force [N, N, N], start (s), duration (s)")
        try:
            fid = robot.frame_id(p["frame"])
        except WbcError as exc:
            raise ConfigError(f"{src}: {where}.frame: {exc}") from exc
        force = np.asarray(p["force"], float)
        if force.shape != (3,):
            raise ConfigError(f"{src}: {where}.force: expected 3 numbers (N), got {p['force']!r}")
        pushes.append({"frame": robot.model.frames[fid].name, "force": force,
                       "start": _number(src, f"{where}.start", p["start"], positive=False),
                       "duration": _number(src, f"{where}.duration", p["duration"])})
    events = []
    for i, ev in enumerate(cfg.get("events") or []):
        where = f"{src}: events[{i}]"
        kinds = [k for k in _EVENT_KINDS if isinstance(ev, dict) and k in ev]
        if len(kinds) != 1 or "time" not in ev:
            raise ConfigError(f"{where}: expected time (s) and exactly one of {list(_EVENT_KINDS)}")
        kind = kinds[0]
        e = {"time": _number(src, f"events[{i}].time", ev["time"], positive=False), "kind": kind,
             "duration": _number(src, f"events[{i}].duration", ev.get("duration", 0.2))}
        if kind in ("release", "remove"):
            e["name"] = str(ev[kind])
        else:
            spec = dict(ev[kind]) if isinstance(ev[kind], dict) else ev[kind]
            if kind == "touchdown" and (not isinstance(spec, dict) or spec.get("type") != "contact"):
                raise ConfigError(f"{where}.touchdown: expected a contact task mapping (type: contact)")
            e["task"] = build_task(spec, f"{where}.{kind}")
            e["task"].bind(robot)
            e["level"] = int(ev.get("level", 0))
            if "trajectory" in ev:
                traj = ev["trajectory"]
                e["trajectory"] = (build_trajectory(traj, 3, f"{where}.trajectory"),
                                   bool(traj.get("absolute", False)))
        events.append(e)
    events.sort(key=lambda e: e["time"])
    sensing = dict(cfg.get("sensing") or {})
    for key in sensing:
        if key not in ("noise_q", "noise_v", "latency_steps"):
            raise ConfigError(f"{src}: sensing.{key}: unknown key; expected noise_q, noise_v, latency_steps")
    return Scenario(
        name=str(cfg.get("name", src.stem)), robot=robot, stack=stack, solver=solver, dt=dt, substeps=substeps,
        duration=_number(src, "duration", cfg.get("duration", 5.0)),
        environment=_environment(src, cfg.get("environment")), pushes=pushes, sensing=sensing,
        references=refs, offsets=offsets, acceptance=dict(cfg.get("acceptance") or {}), events=events, source=src)
