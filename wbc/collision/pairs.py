"""Which self pairs to monitor, and the pair file ``wbc robot collisions ROBOT`` writes.

Default (:func:`default_self_pairs`): every pair of robot geometries, minus the pairs the
SRDF disables (``<disable_collisions>``), minus pairs on one joint or on adjacent joints
(parent and child: they touch at the joint by construction).

Sampled (:func:`sample_self_pairs`, the MoveIt setup assistant's method): of those, keep
only pairs that come within the influence distance in at least one of N random
configurations inside the joint limits; the others can never need a row. Written to
``<robot>.collisions.yaml`` beside the robot YAML (:func:`write_pair_file`), read back by
:class:`~wbc.collision.model.CollisionModel` (:func:`read_pair_file`).
"""

from __future__ import annotations

from pathlib import Path

import pinocchio as pin
import yaml

from ..errors import RobotDefinitionError


def srdf_path(robot) -> Path | None:
    """The robot's SRDF (from its YAML's ``srdf:``), or None."""
    from ..robot.loader import _resolve_file
    from ..robot.schema import check_document
    from ..validation.yamlio import read_document

    if robot.source is None:
        return None
    cfg = check_document(read_document(robot.source, RobotDefinitionError).data)
    return _resolve_file(robot.source, "srdf", cfg["srdf"]) if cfg["srdf"] is not None else None


def default_self_pairs(robot, gm: pin.GeometryModel, n_robot: int) -> list[tuple[str, str]]:
    """Every pair of the first ``n_robot`` geometries minus the SRDF's disabled pairs and the
    pairs on one joint or on adjacent joints (by geometry name)."""
    model = robot.model
    full = pin.GeometryModel()
    for i in range(n_robot):
        full.addGeometryObject(gm.geometryObjects[i])
    full.addAllCollisionPairs()
    srdf = srdf_path(robot)
    if srdf is not None:
        pin.removeCollisionPairs(model, full, str(srdf), False)
    out = []
    for cp in full.collisionPairs:
        ga, gb = full.geometryObjects[cp.first], full.geometryObjects[cp.second]
        ja, jb = ga.parentJoint, gb.parentJoint
        if ja == jb or model.parents[ja] == jb or model.parents[jb] == ja:
            continue
        out.append((ga.name, gb.name))
    return out


def pair_file(robot) -> Path | None:
    return None if robot.source is None else robot.source.with_suffix(".collisions.yaml")


def write_pair_file(robot, pairs: list, summary: dict) -> Path:
    """Write the self pairs to the robot's collision file (its ``primitives:``, if any, kept)."""
    path = pair_file(robot)
    if path is None:
        raise RobotDefinitionError(f"robot '{robot.name}' has no robot YAML to write its collision pairs beside")
    old = _read(path)
    doc = {"robot": robot.name, "method": "MoveIt setup assistant's: default pairs that come within the influence "
                                          "distance in a random configuration", **summary,
           "pairs": [list(p) for p in pairs]}
    if "primitives_fit" in old:
        doc["primitives_fit"] = old["primitives_fit"]
    text = yaml.safe_dump(doc, sort_keys=False, width=200)
    if "primitives" in old:
        text += yaml.safe_dump({"primitives": old["primitives"]}, sort_keys=False, width=200, default_flow_style=None)
    path.write_text(text)
    return path


def write_primitives(robot, primitives: dict, summary: dict) -> Path:
    """Write ``primitives`` (geometry name → :class:`~wbc.collision.primitives.Primitive`) to the robot's collision
    file, under ``primitives:`` (the rest of the file kept)."""
    path = pair_file(robot)
    if path is None:
        raise RobotDefinitionError(f"robot '{robot.name}' has no robot YAML to write its primitives beside")
    doc = _read(path) or {"robot": robot.name}
    doc.pop("primitives", None)
    doc["primitives_fit"] = summary
    prims = {"primitives": {name: p.as_yaml() for name, p in primitives.items()}}
    path.write_text(yaml.safe_dump(doc, sort_keys=False, width=200)
                    + yaml.safe_dump(prims, sort_keys=False, width=200, default_flow_style=None))
    return path


def _read(path: Path) -> dict:
    """The collision file's mapping ({} when absent or not a mapping)."""
    if not path.exists():
        return {}
    doc = yaml.safe_load(path.read_text())
    return doc if isinstance(doc, dict) else {}


def read_pair_file(robot) -> list[tuple[str, str]] | None:
    """The self pairs of the robot's pair file, or None if it has none."""
    path = pair_file(robot)
    if path is None or not path.exists():
        return None
    doc = yaml.safe_load(path.read_text())
    if not isinstance(doc, dict) or not isinstance(doc.get("pairs"), list):
        raise RobotDefinitionError("must be a mapping with 'pairs: [[geometry, geometry], ...]'", key="pairs",
                                   file=path)
    return [tuple(p) for p in doc["pairs"]]
