"""Finding robot descriptions: bundled robot YAMLs and the example-robot-data URDFs.

The URDFs come from the installed ``example-robot-data`` wheel (a cmeel package:
its files live under ``site-packages/cmeel.prefix/share/example-robot-data``). We
locate that directory through the package metadata, never through a hard-coded
path, so the same code works in any virtual environment.
"""

from __future__ import annotations

from functools import cache
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from wbc.errors import RobotDefinitionError, RobotNotFound, WbcError, placed
from wbc.robot.extras import (
    add_offset_frames,
    check_robot,
    level_on_contacts,
    point_contact_frame,
    set_base_position,
    set_joint_value,
)
from wbc.robot.gains import auto_gains
from wbc.robot.schema import N_ROOT, check_document, finite_configuration
from wbc.validation.schema import is_file, show, suggest

if TYPE_CHECKING:
    from wbc.robot.model import RobotModel

#: the bundled robot YAMLs, shipped inside the package (``wbc/data/robots``)
ROBOTS_DIR = Path(__file__).resolve().parents[1] / "data" / "robots"


@cache
def package_share_dir(package: str) -> Path:
    """Directory ``<prefix>/share`` that holds the data of an installed cmeel package.

    URDFs refer to meshes as ``package://<package>/...``, so this is the directory
    to give pinocchio (and ROS_PACKAGE_PATH) as the package directory.
    """
    try:
        dist = metadata.distribution(package)
    except metadata.PackageNotFoundError as exc:
        raise RobotDefinitionError(
            f"package '{package}' is not installed; install it (pip install {package})"
        ) from exc
    for f in dist.files or ():
        parts = Path(str(f)).parts
        if len(parts) >= 3 and parts[0] == "cmeel.prefix" and parts[1] == "share" and parts[2] == package:
            return Path(str(dist.locate_file("cmeel.prefix/share"))).resolve()
    raise RobotDefinitionError(f"package '{package}' has no cmeel.prefix/share/{package} data directory")


def available_robots() -> list[str]:
    """Names of the bundled robot YAMLs (``wbc/data/robots``)."""
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml") if not p.name.endswith(".collisions.yaml"))  # not pair files


def robot_yaml_path(name_or_path: str | Path) -> Path:
    """Resolve a bundled robot name (``"talos"``) or a path to a robot YAML."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml"):
        if not is_file(p):
            raise RobotNotFound(f"robot YAML {show(str(p))} does not exist")
        return p.resolve()
    candidate = ROBOTS_DIR / f"{name_or_path}.yaml"
    if is_file(candidate):
        return candidate
    raise RobotNotFound(
        f"unknown robot {show(str(name_or_path))}: expected one of {available_robots()} "
        "or a path to a robot YAML file"
    )


# --------------------------------------------------------------------- loading
def _resolve_file(src: Path, key: str, spec) -> Path:
    """A file given as ``{package: NAME, path: REL}`` or as a path relative to the YAML
    (``spec`` already checked by :func:`wbc.robot.schema.file_spec`)."""
    if isinstance(spec, dict):
        try:
            base = package_share_dir(spec["package"]) / spec["package"] if "package" in spec else src.parent
        except RobotDefinitionError as exc:
            raise placed(exc, f"{key}.package") from exc
        path = base / spec["path"]
    else:
        path = (src.parent / spec) if not Path(spec).is_absolute() else Path(spec)
    if not is_file(path):
        raise RobotDefinitionError(f"file '{path}' does not exist", key=key)
    return path.resolve()


def _joint(model, name: str, key: str, *, locked: tuple[str, ...] | list[str] = (), one_coordinate: bool = False) -> int:
    """The id of joint ``name`` of ``model``: a joint other than the universe and the root
    (``model`` built with a root joint has it at id 1), with one coordinate if asked."""
    names = [n for jid, n in enumerate(model.names) if jid > 0 and not (jid == 1 and n == "root_joint")]
    if name not in names:
        if name in locked:
            why = "is locked (locked_joints)"
        elif model.existJointName(name):
            why = "is the root joint, not a joint of the robot"
        else:
            why = "is not a joint of the URDF"
        raise RobotDefinitionError(f"'{name}' {why}; expected one of {show(names)}{suggest(name, names)}", key=key)
    jid = model.getJointId(name)
    if one_coordinate and model.joints[jid].nq != 1:
        raise RobotDefinitionError(f"joint '{name}' has {model.joints[jid].nq} coordinates; only a 1-coordinate "
                                   "joint (revolute, prismatic) takes a single value", key=key)
    return jid


def _joint_map(model, key: str, values: dict[str, float], locked: list[str]) -> dict[int, float]:
    """{joint name: value} -> {velocity index: value}, checking the names."""
    out = {}
    for jname, val in values.items():
        jid = _joint(model, jname, f"{key}.{jname}", locked=locked)
        out[model.idx_vs[jid]] = val
    return out


def _parse_urdf(urdf: Path, root: str):
    """The pinocchio model of ``urdf`` with the root joint of ``root``."""
    import pinocchio as pin

    root_joint = {"free_flyer": pin.JointModelFreeFlyer(), "planar": pin.JointModelPlanar()}.get(root)
    try:
        return pin.buildModelFromUrdf(str(urdf), root_joint) if root_joint else pin.buildModelFromUrdf(str(urdf))
    except (RuntimeError, ValueError, OSError) as exc:
        raise RobotDefinitionError(f"pinocchio could not read the URDF '{urdf}': {exc}", key="urdf") from None


def load_robot(name_or_path: str | Path) -> RobotModel:
    """Load a bundled robot (``"talos"``, ``"tiago"``) or a robot YAML file.

    Args:
        name_or_path: a bundled robot's name (:func:`available_robots`) or the path of a robot
            YAML (the schema: :mod:`wbc.robot.schema`).

    Raises:
        RobotNotFound: an unknown name.
        RobotDefinitionError: a malformed YAML, naming the file, line and key path.
    """
    from wbc.validation.yamlio import read_document

    src = robot_yaml_path(name_or_path)
    doc = read_document(src, RobotDefinitionError)
    try:
        return _build(src, check_document(doc.data))
    except WbcError as exc:
        raise placed(exc, file=src, line=doc.line(exc.key), cls=RobotDefinitionError) from exc


def _build(src: Path, cfg: dict) -> RobotModel:
    import pinocchio as pin

    from wbc.robot.joint_compensation import JointCompensation
    from wbc.robot.model import ContactSurface, RobotModel

    root = cfg["root"]
    urdf = _resolve_file(src, "urdf", cfg["urdf"])
    srdf = _resolve_file(src, "srdf", cfg["srdf"]) if cfg["srdf"] is not None else None
    package_dirs = sorted({str(package_share_dir(s["package"])) for s in (cfg["urdf"], cfg["srdf"])
                           if isinstance(s, dict) and "package" in s})      # both found above
    full = _parse_urdf(urdf, root)

    q_ref = pin.neutral(full)
    if srdf is not None:
        try:
            pin.loadReferenceConfigurations(full, str(srdf), False)
        except (RuntimeError, ValueError, OSError) as exc:
            raise RobotDefinitionError(f"pinocchio could not read the SRDF '{srdf}': {exc}", key="srdf") from None
    reference, overrides, key = cfg["posture"]
    if reference is not None:
        names = [k.key() for k in full.referenceConfigurations]
        if reference not in names:
            where = "in the SRDF" if cfg["srdf"] is not None else "(no srdf: is given)"
            raise RobotDefinitionError(f"no reference configuration '{reference}' {where}; expected one of "
                                       f"{names}{suggest(reference, names)}", key=key)
        q_ref = full.referenceConfigurations[reference].copy()
    posture_key = "default_posture.joints" if reference is not None else "default_posture"
    for jname, val in overrides.items():
        jid = _joint(full, jname, f"{posture_key}.{jname}")
        lo, hi = full.lowerPositionLimit[full.idx_qs[jid]], full.upperPositionLimit[full.idx_qs[jid]]
        if full.joints[jid].nq == 1 and not lo - 1e-9 <= val <= hi + 1e-9:
            raise RobotDefinitionError(f"must be inside the joint's limits [{lo:g}, {hi:g}] (rad or m), got {val:g}",
                                       key=f"{posture_key}.{jname}")
        try:        # θ (rad) or d (m); a continuous joint's angle θ as (cos θ, sin θ)
            set_joint_value(full, q_ref, jid, val)
        except RobotDefinitionError as exc:
            raise placed(exc, f"{posture_key}.{jname}") from exc

    locked = cfg["locked"]
    ids = [_joint(full, j, f"locked_joints[{i}]") for i, j in enumerate(locked)]
    model = full
    if locked:
        model = pin.buildReducedModel(full, ids, q_ref)
        # keep the default posture of the joints that remain
        q_new = pin.neutral(model)
        for jid in range(1, model.njoints):
            j_full = full.getJointId(model.names[jid])
            nq_j = model.joints[jid].nq
            q_new[model.idx_qs[jid]: model.idx_qs[jid] + nq_j] = q_ref[full.idx_qs[j_full]: full.idx_qs[j_full] + nq_j]
        q_ref = q_new

    base = cfg["base_position"]
    if base is not None:
        set_base_position(q_ref, root, base)

    frames = add_offset_frames(model, cfg["frames"])      # {link, xyz, rpy} entries become model frames
    for alias, fname in frames.items():
        if not model.existFrame(fname):
            raise RobotDefinitionError(f"the URDF has no frame '{fname}'{_frame_hint(model, fname)}",
                                       key=f"frames.{alias}")

    contacts = {}
    for cname, spec in cfg["contacts"].items():
        spec = dict(spec)
        frame = spec.pop("frame", frames.get(cname, cname))
        if not model.existFrame(frame):
            raise RobotDefinitionError(f"the URDF has no frame '{frame}'{_frame_hint(model, frame)}",
                                       key=f"contacts.{cname}.frame" if "frame" in cfg["contacts"][cname]
                                       else f"contacts.{cname}")
        offset = spec.pop("offset", None)
        if spec.get("kind") == "point":   # the sphere's bottom (radius) and offset: a frame of its own
            frame = point_contact_frame(model, q_ref, cname, frame, spec.get("radius", 0.0), offset)
        contacts[cname] = ContactSurface(name=cname, frame=frame, **spec)
        frames.setdefault(cname, frame)

    if root == "free_flyer" and contacts and cfg["level_on_contacts"]:
        q_ref = finite_configuration(level_on_contacts(model, q_ref, contacts), "contacts")

    n_root = N_ROOT[root]
    limits = cfg["limits"]
    tau_max = model.effortLimit.copy()
    v_max = model.velocityLimit.copy()
    for idx, val in _joint_map(model, "limits.torque", limits["torque"], locked).items():
        tau_max[idx] = val
    for idx, val in _joint_map(model, "limits.velocity", limits["velocity"], locked).items():
        v_max[idx] = val
    for key, arr in (("root_torque", tau_max), ("root_velocity", v_max)):
        if key in limits:
            arr[:n_root] = limits[key]
    if not cfg["actuated_root"]:
        tau_max[:n_root] = np.inf
    tau_max[tau_max > 1e300] = np.inf
    v_max[v_max > 1e300] = np.inf
    q_min = model.lowerPositionLimit.copy()
    q_max = model.upperPositionLimit.copy()
    q_min[q_min < -1e300] = -np.inf
    q_max[q_max > 1e300] = np.inf

    robot = RobotModel(
        name=cfg["name"],
        model=model,
        root=root,
        actuated_root=cfg["actuated_root"],
        frames=frames,
        contacts=contacts,
        q_default=q_ref,
        q_min=q_min,
        q_max=q_max,
        v_max=v_max,
        tau_max=tau_max,
        differential_drive=cfg["differential_drive"],
        default_gains=auto_gains(cfg["gains"], model, q_ref, frames, [c.frame for c in contacts.values()],
                                 root == "free_flyer"),
        urdf_path=urdf,
        package_dirs=package_dirs,
        locked_joints=list(locked),
        source=src,
        compensation=JointCompensation.of_model(model, **cfg["compensate"]),
        position_gains={"kp": _joint_map(model, "position_gains.kp", cfg["position_gains"]["kp"], locked),
                        "kd": _joint_map(model, "position_gains.kd", cfg["position_gains"]["kd"], locked),
                        "saturation_error": cfg["position_gains"]["saturation_error"],
                        "bandwidth": cfg["position_gains"]["bandwidth"]},
    )
    check_robot(robot)        # RobotWarning: static torque over a limit, posture outside limits, tilted contact
    return robot


def _frame_hint(model, name: str) -> str:
    return suggest(name, [f.name for f in model.frames])
