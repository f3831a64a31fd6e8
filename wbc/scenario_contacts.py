"""A scenario's own contacts: surfaces of the robot that touch the environment in this
scenario only (a wiping pad on the hand), added to a copy of the robot.

    contacts:
      hand_pad: {frame: hand, kind: point, offset: [0.08, 0, 0], radius: 0.02, mu: 1.0}

Each entry has the keys of a robot YAML's ``contacts:`` entry (``frame`` a frame name or alias
of the robot, ``kind`` surface | point, ``half_length``/``half_width`` (m, (0, 1]) of a
surface, ``radius`` (m, [0, 0.5]) and ``offset`` ([3] m, in the frame's axes) of a point,
``mu`` in (0, 10]) and the same meaning (:mod:`wbc.robot_extras`): a point with a radius or
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

import pinocchio as pin

from .errors import ConfigError, WbcError, placed
from .model import ContactSurface, RobotModel
from .robot_extras import contact_extras, point_contact_frame
from .schema import mapping, number, suggest, text

KEYS = {"frame", "kind", "half_length", "half_width", "mu", "radius", "offset"}
MAX_MU = 10.0


def _entry(spec: Any, key: str) -> dict:
    spec = mapping(spec, key, allowed=KEYS, required=("frame",),
                   what="a contact mapping {frame, kind, half_length, half_width, radius, offset, mu}")
    out: dict = {"frame": text(spec["frame"], f"{key}.frame", what="a frame name or alias of the robot"),
                 "kind": text(spec.get("kind", "point"), f"{key}.kind", choices=("surface", "point"))}
    for k in ("half_length", "half_width"):
        if k in spec:
            if out["kind"] != "surface":
                raise ConfigError("is for a surface contact (kind: surface)", key=f"{key}.{k}")
            out[k] = number(spec[k], f"{key}.{k}", gt=0, le=1, unit="m")
    if "mu" in spec:
        out["mu"] = number(spec["mu"], f"{key}.mu", gt=0, le=MAX_MU, unit="unitless")
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
