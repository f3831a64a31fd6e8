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
    simulator: pinocchio               # or mujoco (wbc.sim.backends; `wbc run --sim` overrides)
    contacts: {hand_pad: {frame: hand, kind: point, offset: [0.08, 0, 0]}}   # this scenario's own
                                       # contacts, added to a copy of the robot (wbc.scenario.contacts)
    joint_dynamics: false              # true: the URDF's joint damping and friction act in the
                                       # simulator (`wbc run --joint-dynamics` turns it on)
    interaction: {glass: hand, external_force: simulator}   # wbc.interaction.external_force (5.3.5)
    faults: {max_hold_cycles: 20, damping: 10.0, solve_timeout: 0.005}   # wbc.controller.faults: held cycles
                                       # before a stop, the hold torque's damping (1/s), a solve's
                                       # time budget (s; none by default)
    mode: torque                       # or velocity: x = q̇, position-controlled actuators
                                       # (wbc.controller.velocity; `wbc run --mode` overrides)
    walk: {command: {v_x: 0.25, steps: 10}, timing: {single: 0.6, double: 0.2}}   # a walk
                                       # (wbc.scenario.walk_section, wbc.locomotion.walker)

A task may carry ``offset`` (added to its value at the start) or ``trajectory``
(:mod:`wbc.trajectories.position`, an offset from the start value unless ``absolute``).

Everything is checked here, while the :class:`Scenario` is built, and nothing later: ``wbc
validate`` and ``wbc run`` make the same call, so a scenario that validates is one that
runs. The task constructors check their own parameters; :mod:`wbc.scenario.sections` the
plain sections and their ranges; :mod:`wbc.scenario.events` the events against the stack
as it will be when each happens; this module the rest (references between tasks, names,
the robot). Every error is a :class:`~wbc.errors.ConfigError` naming the file, the line
where the YAML has it, the key path, what was expected and what was found:

    tasks/talos_balance.yaml:16: stack[1][0].kp: must be a number >= 0 or a list of 3 numbers >= 0 (1/s²), got [1, 2]
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from wbc.errors import ConfigError, WbcError, placed
from wbc.interaction.external_force import InteractionSpec, interaction_section
from wbc.interaction.hybrid_selection import check_force_tasks
from wbc.locomotion.walker import WalkSpec
from wbc.robot.gains import apply_robot_gains
from wbc.robot.loader import load_robot
from wbc.robot.model import RobotModel
from wbc.scenario import sections as sections
from wbc.scenario.build_tasks import build_task
from wbc.scenario.contacts import with_contacts
from wbc.scenario.events import build_events
from wbc.scenario.examples import scenario_path
from wbc.scenario.walk_section import walk_section
from wbc.sim.backends import SIMULATORS
from wbc.stack import Stack
from wbc.tasks.collision_avoidance import CollisionAvoidance
from wbc.tasks.contact import Contact
from wbc.tasks.contact_wrench import ContactWrench
from wbc.tasks.null_space_impedance import check_in_stack
from wbc.tasks.velocity import check_velocity_stack
from wbc.trajectories.position import build_task_trajectory
from wbc.validation.schema import boolean, mapping, sequence, text
from wbc.validation.yamlio import read_document

#: the control modes a scenario may name (``mode:``)
MODES = ("torque", "velocity")
_TOP = {"name", "robot", "solver", "control", "duration", "environment", "stack", "pushes", "sensing",
        "description", "acceptance", "events", "simulator", "contacts", "joint_dynamics", "interaction",
        "faults", "mode", "walk"}


@dataclass
class Scenario:
    """A validated scenario: the robot, its stack and how to run it (:func:`load_config`).

    Attributes:
        name: the scenario's name (``name:``, else the file's stem).
        robot: the :class:`~wbc.robot.model.RobotModel`, with the scenario's own ``contacts:``.
        stack: the task hierarchy, built and bound to ``robot``.
        solver: the ``solver:`` section: the Controller's keyword arguments (``backend``,
            ``weighting``, ``level_weight``) plus ``type`` (hqp, projection, weighted).
        dt: control period (s).
        substeps: simulator steps per control period (the simulator's step is dt/substeps).
        duration: simulated time (s).
        environment: the shapes of :mod:`wbc.sim.environment` (default a ground, μ = 0.8).
        pushes: ``{frame (URDF name), force (N, world), start (s), duration (s)}`` each.
        sensing: the simulator's measurement options (``noise_q`` (rad, m), ``noise_v``
            (rad/s, m/s) standard deviations, ``latency_steps``); empty: exact, no delay.
        references: task name -> (trajectory, absolute): the tasks whose target moves;
            default none.
        offsets: task name -> its target's offset [x, y, z] from its start value (m); default none.
        acceptance: the ``acceptance:`` thresholds on the run's metrics; default none.
        events: the timeline (release, touchdown, add, remove), each a dict with its time (s);
            default none.
        source: the scenario YAML file; None: built in Python.
        simulator: physics back-end (:data:`wbc.sim.backends.SIMULATORS`); default ``"pinocchio"``.
        joint_dynamics: the URDF's joint damping and friction in the simulator; default False.
        interaction: the external-force source and glass metrics
            (:mod:`wbc.interaction.external_force`); None: none.
        faults: :class:`~wbc.controller.faults.FaultPolicy` keyword arguments; default none.
        mode: ``"torque"`` (default) or ``"velocity"`` (x = q̇, position-controlled actuators:
            :mod:`wbc.controller.velocity`).
        walk: the ``walk:`` section (:mod:`wbc.scenario.walk_section`); None: no walk.
    """

    name: str
    robot: RobotModel
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
    simulator: str = "pinocchio"      # physics back-end (wbc.sim.backends.SIMULATORS)
    joint_dynamics: bool = False      # the URDF's joint damping and friction in the simulator
    interaction: InteractionSpec | None = None   # external-force source and glass metrics (wbc.interaction.external_force)
    faults: dict = field(default_factory=dict)   # FaultPolicy keyword arguments (wbc.controller.faults)
    mode: str = "torque"     # "torque" or "velocity" (wbc.controller.velocity; `wbc run --mode` overrides)
    walk: WalkSpec | None = None      # the walk the run's walker makes (wbc.scenario.walk_section)


def load_config(path: str | Path, *, robot_loader: Callable[[str | Path], Any] | None = None) -> Scenario:
    """Read and validate a scenario YAML (see the module docstring): a path, or the name
    of a bundled scenario (``"talos_balance"``, see :mod:`wbc.scenario.examples`).

    Args:
        path: a scenario YAML file, or a bundled scenario's name.
        robot_loader: turns the ``robot:`` value (a bundled name, or a path resolved against
            the scenario's folder) into a RobotModel; a caller that loads many scenarios may
            pass a caching one. None: :func:`wbc.robot.loader.load_robot`.

    Raises:
        ConfigError: the file is missing or invalid, naming the file, line, key path and what
            was expected.
    """
    src = scenario_path(path)
    doc = read_document(src, ConfigError)
    try:
        return _build(doc.data, src, robot_loader or load_robot)
    except WbcError as exc:
        raise placed(exc, file=src, line=doc.line(exc.key), cls=ConfigError) from exc


def _build(cfg: dict, src: Path, robot_loader) -> Scenario:
    mapping(cfg, None, allowed=_TOP, required=("robot", "stack"))
    name = text(cfg.get("name", src.stem), "name", what="a scenario name")
    for key in ("description",):
        if key in cfg and not isinstance(cfg[key], str):
            raise ConfigError(f"must be text, got {type(cfg[key]).__name__}", key=key)
    acceptance = mapping(cfg.get("acceptance"), "acceptance")
    robot = with_contacts(_robot(cfg["robot"], src, robot_loader), cfg.get("contacts"))   # the scenario's own
    solver = sections.solver_section(cfg.get("solver"))
    dt, substeps = sections.control_section(cfg.get("control"))
    duration = sections.duration_value(cfg.get("duration", 5.0), dt)
    environment = sections.environment_section(cfg.get("environment"))
    stack, refs, offsets = _stack(cfg["stack"], robot, dt)
    for k, level in enumerate(stack.levels):      # collision tasks that keep away from the environment's shapes
        for i, task in enumerate(level):
            if isinstance(task, CollisionAvoidance):
                try:
                    cast(Any, task).use_environment(environment, robot)
                except WbcError as exc:
                    raise placed(exc, f"stack[{k}][{i}]", cls=ConfigError) from exc
    pushes = sections.pushes_section(cfg.get("pushes"), robot, duration)
    events = build_events(cfg.get("events"), robot, stack, dt, duration)
    sensing = sections.sensing_section(cfg.get("sensing"))
    faults = sections.faults_section(cfg.get("faults"))
    interaction = interaction_section(cfg.get("interaction"), robot, stack, pushes)
    simulator = text(cfg.get("simulator", "pinocchio"), "simulator", what=f"one of {', '.join(SIMULATORS)}")
    if simulator not in SIMULATORS:
        raise ConfigError(f"expected one of {', '.join(SIMULATORS)}, got {simulator!r}", key="simulator")
    if simulator == "mujoco" and importlib.util.find_spec("mujoco") is None:      # the run would need it
        raise ConfigError("needs the mujoco package, which is not installed (pip install 'wbc[mujoco]')",
                          key="simulator")
    joint_dynamics = boolean(cfg.get("joint_dynamics", False), "joint_dynamics")
    mode = mode_value(cfg.get("mode", "torque"), stack, solver)
    walk = walk_section(cfg.get("walk"), robot, stack, duration)
    return Scenario(name=name, robot=robot, stack=stack, solver=solver, dt=dt, substeps=substeps, duration=duration,
                    environment=environment, pushes=pushes, sensing=sensing, references=refs, offsets=offsets,
                    acceptance=dict(acceptance), events=events, source=src, simulator=simulator,
                    joint_dynamics=joint_dynamics, interaction=interaction, faults=faults,
                    mode=mode, walk=walk)


def check_mode(sc: Scenario, mode: str | None) -> None:
    """Whether ``sc`` can run in ``mode`` (``wbc run --mode``; None: its own): a ConfigError naming
    the scenario's file, the line and key path of the first task without a velocity form."""
    if mode is None or mode == sc.mode:
        return
    try:
        mode_value(mode, sc.stack, sc.solver)
    except WbcError as exc:
        line = read_document(sc.source, ConfigError).line(exc.key) if sc.source is not None else None
        raise placed(exc, file=sc.source, line=line, cls=ConfigError) from None


def mode_value(value: Any, stack: Stack, solver: dict) -> str:
    """``mode:`` ``torque`` (default) or ``velocity``; a velocity scenario's tasks must all have a
    velocity form (:func:`wbc.tasks.velocity.check_velocity_stack`: the error names ``stack[k][i].type``)
    and its solver no inertia weighting."""
    mode = text(value, "mode", what="torque or velocity")
    if mode not in MODES:
        raise ConfigError(f"expected one of {list(MODES)}, got {mode!r}", key="mode")
    if mode == "velocity":
        check_velocity_stack(stack.levels)
        if solver.get("weighting") not in (None, "identity"):
            raise ConfigError("mode velocity has no inertia matrix: expected weighting identity, got "
                              f"{solver['weighting']!r}", key="solver.weighting")
    return mode


def _robot(value: Any, src: Path, robot_loader):
    name = text(value, "robot", what="a bundled robot name (see `wbc robots`) or a path to a robot YAML")
    target = (src.parent / name) if name.endswith((".yaml", ".yml")) else name
    try:
        return robot_loader(target)
    except WbcError as exc:
        raise placed(exc, "robot", cls=ConfigError) from exc


def _stack(levels: Any, robot, dt: float) -> tuple[Stack, dict, dict]:
    """The stack's tasks, built, bound to ``robot`` and cross-checked; their trajectories
    (name -> (trajectory, absolute)) and offsets (name -> [x, y, z], m)."""
    levels = sequence(levels, "stack", min_len=1, what="a non-empty list of levels (each a list of tasks)")
    built, refs, offsets = [], {}, {}
    where_of: dict[str, str] = {}
    for k, level in enumerate(levels):
        level = sequence(level, f"stack[{k}]", min_len=1, what="a non-empty list of tasks")
        tasks = []
        for i, spec in enumerate(level):
            where = f"stack[{k}][{i}]"
            spec = mapping(spec, where, required=("type",), what="a task mapping with a 'type' key")
            params = {key: v for key, v in spec.items() if key not in ("trajectory", "offset")}
            task = build_task(params, where)
            try:
                task.bind(robot)
                apply_robot_gains(task, spec, robot)     # task kp > robot gains > task default (wbc.robot.gains)
            except WbcError as exc:
                raise placed(exc, where, cls=ConfigError) from exc
            if task.name in where_of:
                raise ConfigError(f"two tasks are named '{task.name}' ({where_of[task.name]} and {where}); names "
                                  "must be unique (set name:)", key=f"{where}.name" if "name" in spec else where)
            where_of[task.name] = where
            for key in ("offset",):         # trajectories: build_task_trajectory checks the axes
                if key not in spec:
                    continue
                if not task.moves_position:
                    raise ConfigError(f"{key} moves the position of a com or frame task, not of a {task.kind} task"
                                      f"{' without position axes (mask)' if task.moves_orientation else ''}",
                                      key=f"{where}.{key}")
            if "trajectory" in spec and "offset" in spec:
                raise ConfigError("give either a trajectory or an offset (the trajectory would override it)",
                                  key=f"{where}.offset")
            if "offset" in spec:
                offsets[task.name] = sections.offset_value(spec["offset"], f"{where}.offset")
            if "trajectory" in spec:
                refs[task.name] = build_task_trajectory(task, spec["trajectory"], f"{where}.trajectory", dt)
            tasks.append(task)
        built.append(tasks)
    stack = Stack(built)          # names are unique (checked above)
    _check_references(stack, where_of, robot)
    return stack, refs, offsets


def _check_references(stack: Stack, where_of: dict[str, str], robot) -> None:
    """Tasks that name other tasks or surfaces: one contact task per surface; a
    contact_wrench names a contact task of the stack, with a target of its force size; what
    a null_space_impedance protects is held by a higher level."""
    held: dict[str, str] = {}
    for t in stack:
        if isinstance(t, Contact):
            if t.contact in held:
                raise ConfigError(f"contact '{t.contact}' is already held by task '{held[t.contact]}' "
                                  f"({where_of[held[t.contact]]})", key=f"{where_of[t.name]}.contact")
            held[t.contact] = t.name
    for name, key, message in check_in_stack(stack, robot):
        raise ConfigError(message, key=f"{where_of[name]}.{key}")
    contacts = {t.name: t for t in stack if isinstance(t, Contact)}
    check_force_tasks(stack, contacts, where_of, robot)
    for t in stack:
        if not isinstance(t, ContactWrench):
            continue
        c = contacts.get(t.contact)
        if c is None:
            raise ConfigError(f"must name a contact task of the stack, got '{t.contact}'; contact tasks: "
                              f"{sorted(contacts)}", key=f"{where_of[t.name]}.contact")
        if t.target is not None and len(t.target) != c.force_dim:
            raise ConfigError(f"must be {c.force_dim} numbers (the force of contact task '{c.name}'), got "
                              f"{len(t.target)}", key=f"{where_of[t.name]}.target")
