"""The plain sections of a scenario YAML, checked and converted: ``solver``, ``control``,
``duration``, ``environment``, ``pushes``, ``sensing``, ``faults``.

Every value is checked for type, shape, finiteness and range here, so that a scenario that
loads is one the runner can run (``wbc validate`` and ``wbc run`` go through the same
:func:`wbc.scenario.loader.load_config`). The ranges, all in SI units:

- ``control.dt``: [1e-5, 0.05] s; ``control.substeps``: an integer in [1, 100];
- ``duration``: (0, 3600] s, at least one control period, at most 10⁷ control cycles;
- ``environment``: ``mu`` in (0, 10]; a ground's ``height`` in [-1, 1] m; an incline's
  ``angle`` in (-π/2, π/2) rad; a box's ``center`` within ±1000 m, ``size`` in (0, 1000] m;
  a plane's ``point`` (m) and non-zero outward ``normal``; a sphere's or (vertical) cylinder's
  ``center`` (m), ``radius`` in (0, 100] m, a cylinder's ``length`` in (0, 1000] m (obstacles:
  the collision task and MuJoCo see them, the own simulator's contact points do not);
  shape names unique (a ground is named ``ground``, an incline ``incline``);
- ``pushes``: a frame of the robot, ``force`` 3 numbers within ±10⁵ N, ``start`` in
  [0, duration) s, ``duration`` in (0, 3600] s;
- ``sensing``: ``noise_q`` in [0, 1] rad or m, ``noise_v`` in [0, 10] rad/s or m/s,
  ``latency_steps`` an integer in [0, 1000];
- ``faults`` (the run-time fault policy, :class:`wbc.controller.faults.FaultPolicy`): ``max_hold_cycles``
  an integer in [0, 10⁴], ``damping`` in [0, 1000] 1/s, ``solve_timeout`` in [1e-6, 1] s;
- ``solver``: ``type`` hqp | projection | weighted, ``backend`` a QP back-end that is
  installed, ``weighting`` identity | inertia, ``level_weight`` in (0, 1], ``damping``
  ``{threshold, max_damping}`` each in [0, 1] (the singularity damping ε and λ_max,
  :class:`~wbc.solvers.cascade.Damping`).

Errors are :class:`~wbc.errors.ConfigError` with the key path (no file: the caller adds it).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wbc.controller.solver_names import SOLVERS
from wbc.errors import ConfigError, SolverError, WbcError, placed
from wbc.sim.environment import Box, Cylinder, HalfSpace, Sphere, ground, incline
from wbc.solvers import SOLVER_OPTIONS
from wbc.solvers.options import check_options
from wbc.validation.schema import integer, mapping, number, sequence, text, vector

WEIGHTINGS = ("identity", "inertia")
DT_RANGE = (1e-5, 0.05)
MAX_SUBSTEPS = 100
MAX_DURATION = 3600.0
MAX_CYCLES = 10_000_000
MAX_MU = 10.0
MAX_PUSH = 1e5
_SHAPE_KEYS = {"ground": {"type", "mu", "height"}, "incline": {"type", "mu", "angle"},
               "box": {"type", "mu", "center", "size", "name"},
               "plane": {"type", "mu", "point", "normal", "name"},
               "sphere": {"type", "mu", "center", "radius", "name"},
               "cylinder": {"type", "mu", "center", "radius", "length", "name"}}
_SHAPE_REQUIRED = {"box": ("center", "size"), "plane": ("point", "normal"), "sphere": ("center", "radius"),
                   "cylinder": ("center", "radius", "length")}


def solver_section(spec: Any) -> dict:
    """``solver:`` -> the Controller's keyword arguments plus ``type`` (default hqp)."""
    spec = mapping(spec if spec is not None else {"type": "hqp"}, "solver",
                   allowed={"type", "backend", "weighting", "level_weight", "damping"})
    out: dict = {"type": text(spec.get("type", "hqp"), "solver.type", choices=SOLVERS)}
    if "backend" in spec:
        name = text(spec["backend"], "solver.backend", what="a QP back-end name (daqp, proxqp, ...)")
        from wbc.solvers.backends import make_backend

        try:
            make_backend(name)          # the run makes the same call: an unknown name fails here
        except SolverError as exc:
            raise placed(exc, "solver.backend", cls=ConfigError) from exc
        out["backend"] = name
    if "weighting" in spec:
        out["weighting"] = text(spec["weighting"], "solver.weighting", choices=WEIGHTINGS)
    if "level_weight" in spec:
        out["level_weight"] = number(spec["level_weight"], "solver.level_weight", gt=0, le=1, unit="unitless")
    if "damping" in spec:
        out["damping"] = damping_value(spec["damping"])
    check_options(out["type"], SOLVER_OPTIONS[out["type"]], {k: v for k, v in out.items() if k != "type"},
                  SOLVER_OPTIONS)
    return out


def damping_value(spec: Any):
    """``solver.damping: {threshold: ε, max_damping: λ_max}`` -> :class:`~wbc.solvers.cascade.Damping`
    (each in [0, 1], units of the level's projected Jacobian; a key left out keeps its default,
    0.01)."""
    from wbc.solvers.cascade import Damping

    spec = mapping(spec, "solver.damping", allowed={"threshold", "max_damping"},
                   what="a mapping {threshold: ε, max_damping: λ_max}")
    d = Damping()
    unit = "units of the projected Jacobian (m/rad for a position row)"
    return Damping(threshold=number(spec.get("threshold", d.threshold), "solver.damping.threshold", ge=0, le=1,
                                    unit=unit),
                   max_damping=number(spec.get("max_damping", d.max_damping), "solver.damping.max_damping", ge=0,
                                      le=1, unit=unit))


def control_section(spec: Any) -> tuple[float, int]:
    """``control:`` -> (dt in s, substeps)."""
    spec = mapping(spec, "control", allowed={"dt", "substeps"})
    dt = number(spec.get("dt", 1e-3), "control.dt", ge=DT_RANGE[0], le=DT_RANGE[1], unit="s")
    substeps = integer(spec.get("substeps", 1), "control.substeps", ge=1, le=MAX_SUBSTEPS)
    return dt, substeps


def duration_value(value: Any, dt: float) -> float:
    """``duration:`` (s): positive, at least one control period ``dt``, at most
    :data:`MAX_CYCLES` cycles."""
    duration = number(value, "duration", gt=0, le=MAX_DURATION, unit="s")
    if round(duration / dt) < 1:
        raise ConfigError(f"must be at least one control period (dt = {dt:g} s), got {duration:g}", key="duration")
    if duration / dt > MAX_CYCLES:
        raise ConfigError(f"{duration:g} s at dt = {dt:g} s is {duration / dt:.3g} control cycles; at most "
                          f"{MAX_CYCLES:.0e}", key="duration")
    return duration


def environment_section(spec: Any) -> list:
    """``environment:`` -> shapes of :mod:`wbc.sim.environment` (default: a ground, mu 0.8)."""
    if spec is None:
        return [ground()]
    shapes: list[HalfSpace | Box | Sphere | Cylinder] = []
    names: dict[str, str] = {}
    for i, s in enumerate(sequence(spec, "environment", what="a list of shapes (ground, incline, plane, box, sphere, cylinder)")):
        where = f"environment[{i}]"
        s = mapping(s, where, required=("type",), what="a shape mapping with a 'type' key")
        kind = text(s["type"], f"{where}.type", choices=sorted(_SHAPE_KEYS))
        mapping(s, where, allowed=_SHAPE_KEYS[kind])
        mu = number(s.get("mu", 0.8), f"{where}.mu", gt=0, le=MAX_MU, unit="unitless")
        shape: HalfSpace | Box | Sphere | Cylinder
        for k in _SHAPE_REQUIRED.get(kind, ()):
            if k not in s:
                raise ConfigError(f"missing (a {kind} needs {', '.join(_SHAPE_REQUIRED[kind])}; lengths in m)",
                                  key=f"{where}.{k}")
        name = text(s.get("name", f"{kind}{i}"), f"{where}.name", what="a shape name")
        if kind == "ground":
            shape = ground(number(s.get("height", 0.0), f"{where}.height", ge=-1, le=1, unit="m"), mu)
        elif kind == "incline":
            shape = incline(number(s.get("angle", 0.0), f"{where}.angle", gt=-math.pi / 2, lt=math.pi / 2,
                                   unit="rad"), mu)
        elif kind == "plane":
            normal = vector(s["normal"], f"{where}.normal", 3, ge=-1e3, le=1e3, unit="unitless")
            if not np.linalg.norm(normal) > 1e-9:
                raise ConfigError(f"must be a non-zero vector (the plane's outward normal), got {normal.tolist()}",
                                  key=f"{where}.normal")
            shape = HalfSpace(vector(s["point"], f"{where}.point", 3, ge=-1e3, le=1e3, unit="m"), normal, mu, name)
        elif kind == "box":
            center = vector(s["center"], f"{where}.center", 3, ge=-1e3, le=1e3, unit="m")
            size = vector(s["size"], f"{where}.size", 3, gt=0, le=1e3, unit="m")
            shape = Box(center, size, mu, name)
        else:
            center = vector(s["center"], f"{where}.center", 3, ge=-1e3, le=1e3, unit="m")
            radius = number(s["radius"], f"{where}.radius", gt=0, le=100, unit="m")
            shape = (Sphere(center, radius, mu, name) if kind == "sphere" else
                     Cylinder(center, radius, number(s["length"], f"{where}.length", gt=0, le=1e3, unit="m"), mu,
                              name))
        key = f"{where}.name" if "name" in s else where
        if shape.name in names:
            raise ConfigError(f"a second shape named '{shape.name}' ({names[shape.name]} is the first); names must "
                              "be unique", key=key)
        names[shape.name] = where
        shapes.append(shape)
    return shapes


def pushes_section(spec: Any, robot, duration: float) -> list[dict]:
    """``pushes:`` -> ``{frame (URDF name), force (N, world), start (s), duration (s)}``."""
    out = []
    for i, p in enumerate(sequence(spec if spec is not None else [], "pushes", what="a list of pushes")):
        where = f"pushes[{i}]"
        p = mapping(p, where, allowed={"frame", "force", "start", "duration"},
                    required=("frame", "force", "start", "duration"))
        frame = text(p["frame"], f"{where}.frame", what="a frame name or alias")
        try:
            fid = robot.frame_id(frame)
        except WbcError as exc:
            raise placed(exc, f"{where}.frame", cls=ConfigError) from exc
        out.append({"frame": robot.model.frames[fid].name,
                    "force": vector(p["force"], f"{where}.force", 3, ge=-MAX_PUSH, le=MAX_PUSH, unit="N"),
                    "start": number(p["start"], f"{where}.start", ge=0, lt=duration,
                                    unit=f"s; inside the run [0, {duration:g})"),
                    "duration": number(p["duration"], f"{where}.duration", gt=0, le=MAX_DURATION, unit="s")})
    return out


def sensing_section(spec: Any) -> dict:
    """``sensing:`` -> the simulator's measurement options (noise std devs, delay)."""
    spec = mapping(spec, "sensing", allowed={"noise_q", "noise_v", "latency_steps"})
    out: dict = {}
    if "noise_q" in spec:
        out["noise_q"] = number(spec["noise_q"], "sensing.noise_q", ge=0, le=1, unit="rad or m")
    if "noise_v" in spec:
        out["noise_v"] = number(spec["noise_v"], "sensing.noise_v", ge=0, le=10, unit="rad/s or m/s")
    if "latency_steps" in spec:
        out["latency_steps"] = integer(spec["latency_steps"], "sensing.latency_steps", ge=0, le=1000,
                                       unit="control periods")
    return out


def faults_section(spec: Any) -> dict:
    """``faults:`` -> the keyword arguments of :class:`wbc.controller.faults.FaultPolicy` it sets (the rest
    keep the policy's defaults: 20 held cycles, damping 10 /s, no time budget)."""
    spec = mapping(spec, "faults", allowed={"max_hold_cycles", "damping", "solve_timeout"})
    out: dict = {}
    if "max_hold_cycles" in spec:
        out["max_hold_cycles"] = integer(spec["max_hold_cycles"], "faults.max_hold_cycles", ge=0, le=10_000,
                                         unit="control cycles")
    if "damping" in spec:
        out["damping"] = number(spec["damping"], "faults.damping", ge=0, le=1000, unit="1/s")
    if "solve_timeout" in spec:
        out["solve_timeout"] = number(spec["solve_timeout"], "faults.solve_timeout", ge=1e-6, le=1.0, unit="s")
    return out


def offset_value(value: Any, key: str) -> np.ndarray:
    """A task's ``offset:`` from its start value: [x, y, z] within ±1000 m."""
    return vector(value, key, 3, ge=-1e3, le=1e3, unit="m")
