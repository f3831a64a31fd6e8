"""Finding robot descriptions: bundled robot YAMLs and the example-robot-data URDFs.

The URDFs come from the installed ``example-robot-data`` wheel (a cmeel package:
its files live under ``site-packages/cmeel.prefix/share/example-robot-data``). We
locate that directory through the package metadata, never through a hard-coded
path, so the same code works in any virtual environment.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .errors import RobotDefinitionError, RobotNotFound

if TYPE_CHECKING:
    from .model import RobotModel

#: the bundled robot YAMLs, shipped inside the package (``wbc/data/robots``)
ROBOTS_DIR = Path(__file__).resolve().parent / "data" / "robots"


@lru_cache(maxsize=None)
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
            return Path(dist.locate_file("cmeel.prefix/share")).resolve()
    raise RobotDefinitionError(f"package '{package}' has no cmeel.prefix/share/{package} data directory")


def available_robots() -> list[str]:
    """Names of the bundled robot YAMLs (``wbc/data/robots``)."""
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml"))


def robot_yaml_path(name_or_path: str | Path) -> Path:
    """Resolve a bundled robot name (``"talos"``) or a path to a robot YAML."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml"):
        if not p.is_file():
            raise RobotNotFound(f"robot YAML '{p}' does not exist")
        return p.resolve()
    candidate = ROBOTS_DIR / f"{name_or_path}.yaml"
    if candidate.is_file():
        return candidate
    raise RobotNotFound(
        f"unknown robot '{name_or_path}': expected one of {available_robots()} "
        "or a path to a robot YAML file"
    )


# --------------------------------------------------------------------- loading
_ROOTS = ("free_flyer", "planar", "fixed")


def _err(src: Path, key: str, msg: str) -> RobotDefinitionError:
    return RobotDefinitionError(f"{src}: key '{key}': {msg}")


def _resolve_file(src: Path, key: str, spec) -> Path:
    """A file given as ``{package: NAME, path: REL}`` or as a path relative to the YAML."""
    if isinstance(spec, dict):
        if set(spec) - {"package", "path"} or "path" not in spec:
            raise _err(src, key, "expected {package: <installed package>, path: <relative path>} or a path")
        base = package_share_dir(spec["package"]) / spec["package"] if "package" in spec else src.parent
        path = base / spec["path"]
    elif isinstance(spec, str):
        path = (src.parent / spec) if not Path(spec).is_absolute() else Path(spec)
    else:
        raise _err(src, key, f"expected a path or {{package, path}}, got {type(spec).__name__}")
    if not path.is_file():
        raise _err(src, key, f"file '{path}' does not exist")
    return path.resolve()


def _float_map(src: Path, key: str, value, model) -> dict[int, float]:
    """{joint_name: float} -> {velocity index: value}, checking joint names."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _err(src, key, f"expected a mapping joint name -> number, got {type(value).__name__}")
    out = {}
    for jname, val in value.items():
        if not model.existJointName(jname):
            raise _err(src, f"{key}.{jname}", f"unknown joint; expected one of {list(model.names)[1:]}")
        if not isinstance(val, (int, float)):
            raise _err(src, f"{key}.{jname}", f"expected a number, got {val!r}")
        out[model.idx_vs[model.getJointId(jname)]] = float(val)
    return out


def _level_on_contacts(model, q, contacts) -> np.ndarray:
    """Make the surface contacts of the default posture lie flat on the ground z = 0.

    A URDF posture with a slightly rolled ankle would otherwise start on a sole
    edge. Gauss-Newton on the joints (root fixed), least-norm steps, on the error
    (height, roll, pitch) of every sole relative to the mean sole height; then the
    root is shifted so the soles touch z = 0.
    """
    import pinocchio as pin

    data = model.createData()
    surfaces = [c for c in contacts.values() if c.kind == "surface"]
    if not surfaces:
        return q
    q = q.copy()
    fids = [model.getFrameId(c.frame) for c in surfaces]
    for _ in range(10):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        z_mean = np.mean([data.oMf[f].translation[2] for f in fids])
        err, rows = [], []
        for f in fids:
            M = data.oMf[f]
            J = pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED)
            rpy = pin.rpy.matrixToRpy(M.rotation)
            err += [M.translation[2] - z_mean, rpy[0], rpy[1]]
            rows += [J[2], J[3], J[4]]
        err = np.array(err)
        if np.abs(err).max() < 1e-10:
            break
        A = np.array(rows)[:, 6:]
        dq = np.zeros(model.nv)
        dq[6:] = -np.linalg.lstsq(A, err, rcond=None)[0]
        q = pin.integrate(model, q, dq)
    pin.framesForwardKinematics(model, data, q)
    q[2] -= np.mean([data.oMf[f].translation[2] for f in fids])
    return q


def load_robot(name_or_path: str | Path) -> "RobotModel":
    """Load a bundled robot (``"talos"``, ``"tiago"``) or a robot YAML file.

    Raises :class:`RobotNotFound` for an unknown name and
    :class:`RobotDefinitionError` naming the file and key for a malformed YAML.
    """
    import pinocchio as pin

    from .model import ContactSurface, RobotModel
    from .yamlio import read_mapping

    src = robot_yaml_path(name_or_path)
    cfg = read_mapping(src, RobotDefinitionError)
    for key in ("name", "urdf", "root"):
        if key not in cfg:
            raise _err(src, key, "missing (required)")
    root = cfg["root"]
    if root not in _ROOTS:
        raise _err(src, "root", f"expected one of {list(_ROOTS)}, got {root!r}")

    urdf = _resolve_file(src, "urdf", cfg["urdf"])
    package_dirs = sorted({str(package_share_dir(s["package"])) for s in (cfg["urdf"], cfg.get("srdf"))
                           if isinstance(s, dict) and "package" in s})
    root_joint = {"free_flyer": pin.JointModelFreeFlyer(), "planar": pin.JointModelPlanar()}.get(root)
    full = pin.buildModelFromUrdf(str(urdf), root_joint) if root_joint else pin.buildModelFromUrdf(str(urdf))

    q_ref = pin.neutral(full)
    if "srdf" in cfg:
        srdf = _resolve_file(src, "srdf", cfg["srdf"])
        pin.loadReferenceConfigurations(full, str(srdf), False)
    posture = cfg.get("default_posture")
    overrides = {}
    if isinstance(posture, dict) and "srdf" in posture:
        overrides = dict(posture.get("joints") or {})
        posture = posture["srdf"]
    if isinstance(posture, str):
        if not full.referenceConfigurations.__contains__(posture):
            names = [k.key() for k in full.referenceConfigurations]
            raise _err(src, "default_posture", f"no reference configuration '{posture}' in the SRDF; expected one of {names}")
        q_ref = full.referenceConfigurations[posture].copy()
    elif isinstance(posture, dict):
        for jname, val in posture.items():
            if not full.existJointName(jname):
                raise _err(src, f"default_posture.{jname}", f"unknown joint; expected one of {list(full.names)[1:]}")
            q_ref[full.idx_qs[full.getJointId(jname)]] = float(val)
    elif posture is not None:
        raise _err(src, "default_posture", "expected an SRDF reference name or a mapping joint -> value")
    for jname, val in overrides.items():
        if not full.existJointName(jname):
            raise _err(src, f"default_posture.joints.{jname}", f"unknown joint; expected one of {list(full.names)[1:]}")
        q_ref[full.idx_qs[full.getJointId(jname)]] = float(val)

    locked = list(cfg.get("locked_joints") or [])
    for jname in locked:
        if not full.existJointName(jname):
            raise _err(src, "locked_joints", f"unknown joint '{jname}'; expected one of {list(full.names)[1:]}")
    model = full
    if locked:
        model = pin.buildReducedModel(full, [full.getJointId(j) for j in locked], q_ref)
        # keep the default posture of the joints that remain
        q_new = pin.neutral(model)
        for jid in range(1, model.njoints):
            j_full = full.getJointId(model.names[jid])
            nq_j = model.joints[jid].nq
            q_new[model.idx_qs[jid]: model.idx_qs[jid] + nq_j] = q_ref[full.idx_qs[j_full]: full.idx_qs[j_full] + nq_j]
        q_ref = q_new

    base = cfg.get("base_position")
    if base is not None:
        if root == "fixed" or len(base) not in (2, 3):
            raise _err(src, "base_position", "expected [x, y] or [x, y, z] for a floating or planar root")
        q_ref[: len(base)] = base

    frames = cfg.get("frames") or {}
    for alias, fname in frames.items():
        if not model.existFrame(fname):
            raise _err(src, f"frames.{alias}", f"URDF has no frame '{fname}'")

    contacts = {}
    for cname, spec in (cfg.get("contacts") or {}).items():
        spec = dict(spec or {})
        frame = spec.pop("frame", frames.get(cname, cname))
        if not model.existFrame(frame):
            raise _err(src, f"contacts.{cname}.frame", f"URDF has no frame '{frame}'")
        kind = spec.get("kind", "surface")
        if kind not in ("surface", "point"):
            raise _err(src, f"contacts.{cname}.kind", f"expected 'surface' or 'point', got {kind!r}")
        try:
            contacts[cname] = ContactSurface(name=cname, frame=frame, **spec)
        except TypeError as exc:
            raise _err(src, f"contacts.{cname}", f"unexpected field ({exc}); expected kind, half_length, half_width, mu") from exc
        if contacts[cname].mu <= 0 or contacts[cname].half_length <= 0 or contacts[cname].half_width <= 0:
            raise _err(src, f"contacts.{cname}", "mu, half_length and half_width must be positive")
        frames.setdefault(cname, frame)

    if root == "free_flyer" and contacts and cfg.get("level_on_contacts", True):
        q_ref = _level_on_contacts(model, q_ref, contacts)

    n_root = {"free_flyer": 6, "planar": 3, "fixed": 0}[root]
    limits = cfg.get("limits") or {}
    tau_max = model.effortLimit.copy()
    v_max = model.velocityLimit.copy()
    for idx, val in _float_map(src, "limits.torque", limits.get("torque"), model).items():
        tau_max[idx] = val
    for idx, val in _float_map(src, "limits.velocity", limits.get("velocity"), model).items():
        v_max[idx] = val
    for key, arr in (("root_torque", tau_max), ("root_velocity", v_max)):
        if key in limits:
            val = limits[key]
            if not (isinstance(val, list) and len(val) == n_root):
                raise _err(src, f"limits.{key}", f"expected a list of {n_root} numbers")
            arr[:n_root] = val
    if not cfg.get("actuated_root", False):
        tau_max[:n_root] = np.inf
    tau_max[tau_max > 1e300] = np.inf
    v_max[v_max > 1e300] = np.inf
    q_min = model.lowerPositionLimit.copy()
    q_max = model.upperPositionLimit.copy()
    q_min[q_min < -1e300] = -np.inf
    q_max[q_max > 1e300] = np.inf

    return RobotModel(
        name=str(cfg["name"]),
        model=model,
        root=root,
        actuated_root=bool(cfg.get("actuated_root", False)),
        frames=dict(frames),
        contacts=contacts,
        q_default=q_ref,
        q_min=q_min,
        q_max=q_max,
        v_max=v_max,
        tau_max=tau_max,
        differential_drive=bool(cfg.get("differential_drive", False)),
        default_gains=dict(cfg.get("gains") or {}),
        urdf_path=urdf,
        package_dirs=package_dirs,
        locked_joints=locked,
        source=src,
    )
