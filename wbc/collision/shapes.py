"""Obstacles of the environment as coal geometries: spheres, boxes, cylinders, capsules, planes.

An obstacle is fixed in the world: ``{type: sphere, center: [x, y, z], radius: r}``,
``{type: box, center, size: [sx, sy, sz]}`` (axis-aligned), ``{type: cylinder, center,
radius, length}`` and ``{type: capsule, ...}`` (axis along z), ``{type: plane, height}``
(the half-space z ≤ height, e.g. the ground). Lengths in m. The scenario's ``environment:``
ground and boxes become planes and boxes (:func:`from_environment`).
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from ..errors import ConfigError
from ..validation.schema import mapping, number, text, vector

_KEYS = {"sphere": ("radius",), "box": ("size",), "cylinder": ("radius", "length"), "capsule": ("radius", "length"),
         "plane": ("height",)}


@dataclass
class Obstacle:
    """One fixed obstacle: its name, coal geometry and world placement."""

    name: str
    geometry: object
    placement: pin.SE3


def obstacle(spec, where: str, default_name: str) -> Obstacle:
    """An :class:`Obstacle` from its YAML mapping (ConfigError naming ``where``'s key otherwise)."""
    spec = mapping(spec, where, required=("type",), what="an obstacle mapping with a 'type' key")
    kind = text(spec["type"], f"{where}.type", choices=sorted(_KEYS), what="an obstacle type")
    allowed = {"type", "name", *_KEYS[kind]} | ({"center"} if kind != "plane" else set())
    mapping(spec, where, allowed=allowed, required=tuple(sorted(allowed - {"name"})))
    name = text(spec.get("name", default_name), f"{where}.name", what="an obstacle name")
    if kind == "plane":
        h = number(spec["height"], f"{where}.height", ge=-100, le=100, unit="m", error=ConfigError)
        return Obstacle(name, coal.Halfspace(np.array([0.0, 0.0, 1.0]), h), pin.SE3.Identity())
    center = vector(spec["center"], f"{where}.center", 3, unit="m", error=ConfigError)
    if np.any(np.abs(center) > 1000):
        raise ConfigError(f"must be within ±1000 m, got {center.tolist()}", key=f"{where}.center")
    place = pin.SE3(np.eye(3), center)
    if kind == "box":
        size = vector(spec["size"], f"{where}.size", 3, unit="m", error=ConfigError)
        if np.any(size <= 0) or np.any(size > 1000):
            raise ConfigError(f"must be 3 sizes in (0, 1000] m, got {size.tolist()}", key=f"{where}.size")
        return Obstacle(name, coal.Box(*size), place)
    r = number(spec["radius"], f"{where}.radius", gt=0, le=100, unit="m", error=ConfigError)
    if kind == "sphere":
        return Obstacle(name, coal.Sphere(r), place)
    length = number(spec["length"], f"{where}.length", gt=0, le=1000, unit="m", error=ConfigError)
    return Obstacle(name, (coal.Cylinder if kind == "cylinder" else coal.Capsule)(r, length), place)


def from_environment(shapes) -> list[Obstacle]:
    """The scenario environment's shapes (:mod:`wbc.sim.environment`: ground, incline and planes
    as half-spaces, boxes, spheres, vertical cylinders) as obstacles, by their names."""
    from ..sim.environment import Box, Cylinder, HalfSpace, Sphere

    out = []
    for s in shapes:
        if isinstance(s, Box):
            out.append(Obstacle(s.name, coal.Box(*s.size), pin.SE3(np.eye(3), np.asarray(s.center, dtype=float))))
        elif isinstance(s, HalfSpace):
            n = np.asarray(s.normal, dtype=float)
            out.append(Obstacle(s.name, coal.Halfspace(n, float(n @ s.point)), pin.SE3.Identity()))
        elif isinstance(s, Sphere):
            out.append(Obstacle(s.name, coal.Sphere(float(s.radius)), pin.SE3(np.eye(3), s.center)))
        elif isinstance(s, Cylinder):
            out.append(Obstacle(s.name, coal.Cylinder(float(s.radius), float(s.length)),
                                pin.SE3(np.eye(3), s.center)))
        else:
            raise TypeError(f"no collision geometry for environment shape {type(s).__name__}")
    return out
