"""The robot YAML's schema (``wbc/data/robots/*.yaml``), checked before the URDF is read.

    name: talos                                   # required, text
    urdf: {package: example-robot-data, path: robots/.../talos_reduced.urdf}   # or a path
    srdf: {package: ..., path: ...}               # optional
    root: free_flyer                              # free_flyer | planar | fixed (required)
    actuated_root: false                          # true/false
    differential_drive: false                     # true/false (a planar root only)
    level_on_contacts: true                       # true/false
    default_posture: half_sitting                 # an SRDF configuration, {joint: value}, or
                                                  # {srdf: NAME, joints: {joint: value}} (rad or m)
    locked_joints: [wheel_left_joint]             # joint names, not the root
    base_position: [0.0, 0.0, 1.0]                # free flyer: [x, y] or [x, y, z] (m); planar: [x, y] (m)
                                                  # or [x, y, yaw] (m, m, rad)
    frames: {left_foot: left_sole_link,           # alias -> URDF frame, or an offset frame added to
             sole: {link: NAME, xyz: [0, 0, -0.03], rpy: [0, 0, 0]}}   # the model (m, rad)
    contacts:                                     # name -> surface or point
      left_foot: {frame: left_sole_link, kind: surface, half_length: 0.1, half_width: 0.065, mu: 0.7}
      fl_foot: {frame: FL_foot, kind: point, radius: 0.022, offset: [0, 0, 0], mu: 0.7}   # m
    limits: {torque: {joint: N·m}, velocity: {joint: rad/s}, root_torque: [...], root_velocity: [...]}
    gains: {com: 100.0, torso: auto}              # task kind or task name -> default kp (1/s²), or
                                                  # auto: from the robot's inertia (wbc.robot.gains)
    compensate: {damping: true, friction: true,   # the controller's model adds the URDF's joint
                 friction_velocity: 0.01}         # damping and friction (wbc.robot.joint_compensation); rad/s
    position_gains: {kp: {joint: N·m/rad}, kd: {joint: N·m·s/rad},   # position-controlled actuators'
                     saturation_error: 0.01,      # servo gains (wbc.robot.servo): joints not listed get
                     bandwidth: 150.0}            # kp = min(τ_max/saturation_error, M_ii bandwidth²), kd critical

Unknown keys are refused with a did-you-mean; every value's type, length and range is
checked (contact sizes in (0, 1] m, mu in (0, 10], limits >= 1e-6 with ``.inf`` for none,
positions within ±1000 m). What needs the model (joint and frame names, joint limits) is
checked by :func:`wbc.robot.loader.load_robot` once the URDF is read. Errors are
:class:`~wbc.errors.RobotDefinitionError` with the key path; the loader adds file and line.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wbc.errors import RobotDefinitionError
from wbc.robot.extras import contact_extras, frame_entry
from wbc.robot.joint_compensation import FRICTION_VELOCITY
from wbc.validation.schema import boolean, mapping, number, sequence, text, vector

ROOTS = ("free_flyer", "planar", "fixed")
N_ROOT = {"free_flyer": 6, "planar": 3, "fixed": 0}
KEYS = {"name", "urdf", "srdf", "root", "actuated_root", "differential_drive", "level_on_contacts",
        "default_posture", "locked_joints", "base_position", "frames", "contacts", "limits", "gains",
        "compensate", "position_gains"}
CONTACT_KEYS = {"frame", "kind", "half_length", "half_width", "mu", "radius", "offset"}
LIMIT_KEYS = {"torque", "velocity", "root_torque", "root_velocity"}
MAX_MU = 10.0
#: smallest torque or velocity limit (N·m, N, rad/s, m/s): below, 1/limit overflows in the metrics
MIN_LIMIT = 1e-6


def file_spec(value: Any, key: str) -> Any:
    """``urdf:``/``srdf:``: a path (text) or ``{package: NAME, path: RELATIVE}``."""
    if isinstance(value, dict):
        mapping(value, key, allowed={"package", "path"}, required=("path",), error=RobotDefinitionError)
        text(value["path"], f"{key}.path", what="a path", error=RobotDefinitionError)
        if "package" in value:
            text(value["package"], f"{key}.package", what="an installed package's name", error=RobotDefinitionError)
        return value
    return text(value, key, what="a path or {package: <installed package>, path: <relative path>}", error=RobotDefinitionError)


def joint_values(value: Any, key: str, *, ge: float | None = None, allow_inf: bool = False,
                 unit: str = "") -> dict[str, float]:
    """A mapping joint name -> number (names checked later against the model)."""
    spec = mapping(value, key, what="a mapping joint name -> number", error=RobotDefinitionError)
    return {j: number(v, f"{key}.{j}", ge=ge, allow_inf=allow_inf, unit=unit, error=RobotDefinitionError)
            for j, v in spec.items()}


def check_document(cfg: dict) -> dict:
    """The robot YAML's data checked (module docstring) and normalised: numbers as floats,
    vectors as arrays, defaults filled in. Raises :class:`RobotDefinitionError`."""
    mapping(cfg, None, allowed=KEYS, required=("name", "urdf", "root"), error=RobotDefinitionError)
    out: dict = {"name": text(cfg["name"], "name", what="a robot name", error=RobotDefinitionError),
                 "urdf": file_spec(cfg["urdf"], "urdf"),
                 "srdf": file_spec(cfg["srdf"], "srdf") if "srdf" in cfg else None,
                 "root": text(cfg["root"], "root", choices=ROOTS, error=RobotDefinitionError)}
    for key, default in (("actuated_root", False), ("differential_drive", False), ("level_on_contacts", True)):
        out[key] = boolean(cfg.get(key, default), key, error=RobotDefinitionError)
    if out["differential_drive"] and out["root"] != "planar":
        raise RobotDefinitionError(f"a differential drive needs root: planar, got root: {out['root']}", key="differential_drive")
    out["posture"] = _posture(cfg.get("default_posture"))
    locked = sequence(cfg.get("locked_joints") or [], "locked_joints", what="a list of joint names", error=RobotDefinitionError)
    for i, j in enumerate(locked):
        text(j, f"locked_joints[{i}]", what="a joint name", error=RobotDefinitionError)
        if j in locked[:i]:
            raise RobotDefinitionError(f"joint '{j}' is listed twice", key=f"locked_joints[{i}]")
    out["locked"] = list(locked)
    out["base_position"] = None
    if cfg.get("base_position") is not None:
        lengths = {"free_flyer": (2, 3), "planar": (2, 3), "fixed": ()}[out["root"]]
        if not lengths:
            raise RobotDefinitionError("a fixed root has no base position", key="base_position")
        out["base_position"] = vector(cfg["base_position"], "base_position", lengths, ge=-1e3, le=1e3, unit="m",
                                      error=RobotDefinitionError)
    frames = mapping(cfg.get("frames"), "frames", what="a mapping alias -> URDF frame name", error=RobotDefinitionError)
    out["frames"] = {a: frame_entry(f, f"frames.{a}") for a, f in frames.items()}
    contacts = mapping(cfg.get("contacts"), "contacts", what="a mapping contact name -> {frame, kind, ...}",
                       error=RobotDefinitionError)
    out["contacts"] = {c: _contact(spec, f"contacts.{c}") for c, spec in contacts.items()}
    out["limits"] = _limits(cfg.get("limits"), N_ROOT[out["root"]])
    gains = mapping(cfg.get("gains"), "gains", what="a mapping task kind -> default kp (1/s²)", error=RobotDefinitionError)
    out["gains"] = {k: v if v == "auto" else number(v, f"gains.{k}", ge=0, unit="1/s² (or auto)",
                                                    error=RobotDefinitionError)
                    for k, v in gains.items()}
    out["compensate"] = _compensate(cfg.get("compensate"))
    servo = mapping(cfg.get("position_gains"), "position_gains", allowed={"kp", "kd", "saturation_error", "bandwidth"},
                    error=RobotDefinitionError)
    out["position_gains"] = {
        "kp": joint_values(servo.get("kp", {}), "position_gains.kp", ge=0, unit="N·m/rad or N/m"),
        "kd": joint_values(servo.get("kd", {}), "position_gains.kd", ge=0, unit="N·m·s/rad or N·s/m"),
        "saturation_error": number(servo.get("saturation_error", 0.01), "position_gains.saturation_error", gt=0,
                                   le=1, unit="rad or m", error=RobotDefinitionError),
        "bandwidth": number(servo.get("bandwidth", 150.0), "position_gains.bandwidth", gt=0, le=1e4, unit="rad/s",
                            error=RobotDefinitionError)}
    return out


def _compensate(value: Any) -> dict:
    """``compensate:`` -> JointCompensation.of_model's keyword arguments (all off by default)."""
    spec = mapping(value, "compensate", allowed={"damping", "friction", "friction_velocity"},
                   what="a mapping {damping: true/false, friction: true/false, friction_velocity: rad/s}",
                   error=RobotDefinitionError)
    return {"damping": boolean(spec.get("damping", False), "compensate.damping", error=RobotDefinitionError),
            "friction": boolean(spec.get("friction", False), "compensate.friction", error=RobotDefinitionError),
            "friction_velocity": number(spec.get("friction_velocity", FRICTION_VELOCITY),
                                        "compensate.friction_velocity", gt=0, le=10, unit="rad/s or m/s",
                                        error=RobotDefinitionError)}


def _posture(value: Any) -> tuple[str | None, dict[str, float], str]:
    """(SRDF configuration name or None, joint -> value overrides, key path of the name)."""
    if value is None:
        return None, {}, "default_posture"
    if isinstance(value, str):
        name = text(value, "default_posture", what="an SRDF configuration name", error=RobotDefinitionError)
        return name, {}, "default_posture"
    spec = mapping(value, "default_posture", what="an SRDF configuration name or a mapping joint -> value",
                   error=RobotDefinitionError)
    if "srdf" in spec:
        mapping(spec, "default_posture", allowed={"srdf", "joints"}, error=RobotDefinitionError)
        name = text(spec["srdf"], "default_posture.srdf", what="an SRDF configuration name", error=RobotDefinitionError)
        return name, joint_values(spec.get("joints"), "default_posture.joints", unit="rad or m"), "default_posture.srdf"
    return None, joint_values(spec, "default_posture", unit="rad or m"), "default_posture"


def _contact(spec: Any, key: str) -> dict:
    spec = mapping(spec, key, allowed=CONTACT_KEYS, what="a contact mapping {frame, kind, half_length, half_width, mu}",
                   error=RobotDefinitionError)
    out: dict = {}
    if "frame" in spec:
        out["frame"] = text(spec["frame"], f"{key}.frame", what="a URDF frame name", error=RobotDefinitionError)
    if "kind" in spec:
        out["kind"] = text(spec["kind"], f"{key}.kind", choices=("surface", "point"), error=RobotDefinitionError)
    for k in ("half_length", "half_width"):
        if k in spec:
            out[k] = number(spec[k], f"{key}.{k}", gt=0, le=1, unit="m", error=RobotDefinitionError)
    if "mu" in spec:
        out["mu"] = number(spec["mu"], f"{key}.mu", gt=0, le=MAX_MU, unit="unitless", error=RobotDefinitionError)
    out.update(contact_extras(spec, key))
    return out


def _limits(value: Any, n_root: int) -> dict:
    spec = mapping(value, "limits", allowed=LIMIT_KEYS, error=RobotDefinitionError)
    out: dict = {"torque": joint_values(spec.get("torque"), "limits.torque", ge=MIN_LIMIT, allow_inf=True,
                                        unit="N·m or N; .inf for none"),
                 "velocity": joint_values(spec.get("velocity"), "limits.velocity", ge=MIN_LIMIT, allow_inf=True,
                                          unit="rad/s or m/s; .inf for none")}
    for key, unit in (("root_torque", "N and N·m"), ("root_velocity", "m/s and rad/s")):
        if key in spec:
            if n_root == 0:
                raise RobotDefinitionError("a fixed root has no root limits", key=f"limits.{key}")
            out[key] = vector(spec[key], f"limits.{key}", n_root, ge=MIN_LIMIT, allow_inf=True,
                              unit=f"{unit}; .inf for none", error=RobotDefinitionError)
    return out


def finite_configuration(q: np.ndarray, key: str) -> np.ndarray:
    """The default configuration must be finite (a check after leveling the soles)."""
    if not np.all(np.isfinite(q)):
        raise RobotDefinitionError("the default configuration is not finite after leveling the contacts on the ground "
                "(set level_on_contacts: false, or check the contacts' frames)", key=key)
    return q
