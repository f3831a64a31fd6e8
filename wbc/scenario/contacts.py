"""A scenario's own contacts: surfaces of the robot that touch the environment in this
scenario only (a wiping pad on the hand), added to a copy of the robot.

    contacts:
      hand_pad: {frame: hand, kind: point, offset: [0.08, 0, 0], radius: 0.02, mu: 1.0}

Each entry has the keys of a robot YAML's ``contacts:`` entry (``frame`` a frame name or alias
of the robot, ``kind`` surface | point, ``half_length``/``half_width`` (m, (0, 1]) of a
surface, ``radius`` (m, [0, 0.5]) and ``offset`` ([3] m, in the frame's axes) of a point,
``mu`` in (0, 10]) and the same meaning (:mod:`wbc.robot.extras`), and for a point ``mujoco``
(``{solref: [2], solimp: [3 to 5], solreffriction: [2]}``, MuJoCo's meanings: the MuJoCo
back-end's contact parameters of its sphere against the environment, see
:mod:`wbc.sim.mujoco_sim`, "Point contacts sliding"; ignored by wbc.sim): a point with a radius or
an offset gets a frame ``<name>_point`` of its own at the touching point (the sphere's bottom
at the default posture, oriented like the world there); the contact's name becomes a frame
alias. Unlike the robot's own contacts, these are not levelled onto the ground and not part
of the robot's load-time checks (a hand is not a foot).

The robot returned is a copy (its pinocchio model copied, frames added there): the robot
that was loaded, which a caller may share between scenarios, is unchanged. Both simulators
then model the contact (:func:`wbc.sim.simulator.contact_points` reads ``robot.contacts``):
the pinocchio one at the point (or the sole's corners), MuJoCo with a 5 mm sphere at a point.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.errors import ConfigError, WbcError, placed
from wbc.robot.extras import contact_extras, point_contact_frame
from wbc.robot.model import ContactSurface, RobotModel
from wbc.validation.schema import mapping, number, suggest, text, vector

KEYS = {"frame", "kind", "half_length", "half_width", "mu", "radius", "offset", "mujoco"}
MAX_MU = 10.0
MUJOCO_KEYS = ("solref", "solimp", "solreffriction")


def _mujoco(spec: Any, key: str) -> tuple:
    """``mujoco: {solref: [2], solimp: [3 to 5], solreffriction: [2]}`` of a point contact: the
    MuJoCo back-end's contact parameters of its sphere against the environment (MuJoCo's
    meaning: solref (time constant s, damping ratio) or (−stiffness, −damping); solimp (d0,
    d_width, width m[, midpoint, power]) with d in (0, 1); solreffriction the friction
    dimensions' solref). Ignored by wbc.sim. As a tuple of (name, values) pairs."""
    spec = mapping(spec, key, allowed=set(MUJOCO_KEYS), what="a mapping {solref, solimp, solreffriction}")
    out = []
    for k in MUJOCO_KEYS:
        if k not in spec:
            continue
        where = f"{key}.{k}"
        if k == "solimp":
            v = vector(spec[k], where, (3, 4, 5), unit="unitless, m")
            if not (0 < v[0] < 1 and 0 < v[1] < 1 and v[2] > 0):
                raise ConfigError(f"must have d0, d_width in (0, 1) and a width > 0 (m), got {v.tolist()}", key=where)
        else:
            v = vector(spec[k], where, 2, unit="s and unitless, or −N/m/kg and −N·s/m/kg")
            if not (np.all(v > 0) or np.all(v < 0) or (k == "solreffriction" and np.all(v == 0))):
                raise ConfigError(f"must be (time constant > 0, damping ratio > 0) or (−stiffness, −damping), "
                                  f"got {v.tolist()}", key=where)
        out.append((k, tuple(float(x) for x in v)))
    return tuple(out)


def _entry(spec: Any, key: str) -> dict:
    spec = mapping(spec, key, allowed=KEYS, required=("frame",),
                   what="a contact mapping {frame, kind, half_length, half_width, radius, offset, mu, mujoco}")
    out: dict = {"frame": text(spec["frame"], f"{key}.frame", what="a frame name or alias of the robot"),
                 "kind": text(spec.get("kind", "point"), f"{key}.kind", choices=("surface", "point"))}
    for k in ("half_length", "half_width"):
        if k in spec:
            if out["kind"] != "surface":
                raise ConfigError("is for a surface contact (kind: surface)", key=f"{key}.{k}")
            out[k] = number(spec[k], f"{key}.{k}", gt=0, le=1, unit="m")
    if "mu" in spec:
        out["mu"] = number(spec["mu"], f"{key}.mu", gt=0, le=MAX_MU, unit="unitless")
    if "mujoco" in spec:
        if out["kind"] != "point":
            raise ConfigError("is for a point contact (kind: point)", key=f"{key}.mujoco")
        out["mujoco"] = _mujoco(spec["mujoco"], f"{key}.mujoco")
    try:
        out.update(contact_extras({**spec, "kind": out["kind"]}, key))
    except WbcError as exc:
        raise placed(exc, cls=ConfigError) from exc
    return out


def with_contacts(robot: RobotModel, spec: Any, key: str = "contacts") -> RobotModel:
    """``robot``, or (``spec`` a non-empty ``contacts:`` mapping) a copy of it with those
    contacts added (module docstring). Raises :class:`ConfigError` under ``key``."""
    entries = mapping(spec, key, what="a mapping contact name -> {frame, kind, ...}")
    if not entries:
        return robot
    model = pin.Model(robot.model)
    contacts, frames = dict(robot.contacts), dict(robot.frames)
    for name, raw in entries.items():
        where = f"{key}.{name}"
        c = _entry(raw, where)
        if name in contacts:
            raise ConfigError(f"the robot already has a contact named '{name}'; give this one another name", key=where)
        if name in frames:
            raise ConfigError(f"the robot already has a frame alias '{name}'; give the contact another name",
                              key=where)
        alias = c.pop("frame")
        frame = frames.get(alias, alias)
        if not model.existFrame(frame):
            raise ConfigError(f"the robot has no frame or alias '{alias}'{suggest(alias, frames)}",
                              key=f"{where}.frame")
        offset = c.pop("offset", None)
        if c["kind"] == "point":
            try:
                frame = point_contact_frame(model, robot.q_default, name, frame, c.get("radius", 0.0), offset)
            except WbcError as exc:
                raise placed(exc, where, cls=ConfigError) from exc
        contacts[name] = ContactSurface(name=name, frame=frame, **c)
        frames[name] = frame
    return dataclasses.replace(robot, model=model, contacts=contacts, frames=frames)
