"""What the robot can touch: half-spaces (the ground, an incline, a plane) and boxes (a table);
and obstacles: spheres and cylinders.

Each contact surface (:class:`HalfSpace`, :class:`Box`) answers, for a world point p, whether it
is in (or near) contact: its signed depth (m, > 0 inside), the contact frame (rotation whose z
is the outward normal) and its friction coefficient μ. The obstacles (:class:`Sphere`,
:class:`Cylinder`; ``contact_surface = False``) are for the collision task (kept away from the
chosen links, :mod:`wbc.collision.shapes`) and for MuJoCo (real geoms); the own simulator's
contact points (feet, hand pads) do not touch them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def frame_from_normal(n: np.ndarray) -> np.ndarray:
    """A rotation matrix whose third column is the unit normal n."""
    n = n / np.linalg.norm(n)
    t = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = t - n * (t @ n)
    t1 /= np.linalg.norm(t1)
    return np.column_stack([t1, np.cross(n, t1), n])


@dataclass
class HalfSpace:
    """Everything below the plane through ``point`` with outward ``normal`` is solid."""

    point: np.ndarray
    normal: np.ndarray
    mu: float = 0.8
    name: str = "ground"
    contact_surface = True

    def __post_init__(self) -> None:
        self.point = np.asarray(self.point, dtype=float)
        self.normal = np.asarray(self.normal, dtype=float) / np.linalg.norm(self.normal)
        self.R = frame_from_normal(self.normal)

    def depth(self, p: np.ndarray) -> float:
        return float(self.normal @ (self.point - p))

    def depths(self, P: np.ndarray) -> np.ndarray:
        """:meth:`depth` of each row of P (n × 3)."""
        return (self.point - P) @ self.normal


def ground(height: float = 0.0, mu: float = 0.8) -> HalfSpace:
    return HalfSpace(np.array([0.0, 0.0, height]), np.array([0.0, 0.0, 1.0]), mu, "ground")


def incline(angle: float, mu: float) -> HalfSpace:
    """A plane through the origin tilted by ``angle`` (rad) about the world y axis."""
    n = np.array([-np.sin(angle), 0.0, np.cos(angle)])
    return HalfSpace(np.zeros(3), n, mu, "incline")


@dataclass
class Box:
    """An axis-aligned box (a table); contact on its top face only. Sizes in m."""

    center: np.ndarray
    size: np.ndarray
    mu: float = 0.5
    name: str = "box"
    contact_surface = True

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, dtype=float)
        self.size = np.asarray(self.size, dtype=float)
        self.normal = np.array([0.0, 0.0, 1.0])
        self.R = np.eye(3)
        self.top = self.center[2] + 0.5 * self.size[2]

    def depth(self, p: np.ndarray) -> float:
        half = 0.5 * self.size
        if np.any(np.abs(p[:2] - self.center[:2]) > half[:2]):
            return -np.inf
        d = self.top - p[2]
        return d if d < self.size[2] else -np.inf

    def depths(self, P: np.ndarray) -> np.ndarray:
        """:meth:`depth` of each row of P (n × 3)."""
        half = 0.5 * self.size
        d = self.top - P[:, 2]
        outside = np.any(np.abs(P[:, :2] - self.center[:2]) > half[:2], axis=1) | (d >= self.size[2])
        return np.where(outside, -np.inf, d)


@dataclass
class Sphere:
    """A fixed sphere obstacle: centre (m, world) and radius (m)."""

    center: np.ndarray
    radius: float
    mu: float = 0.5
    name: str = "sphere"
    contact_surface = False

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, dtype=float)


@dataclass
class Cylinder:
    """A fixed cylinder obstacle, axis along the world z: centre (m), radius and length (m)."""

    center: np.ndarray
    radius: float
    length: float
    mu: float = 0.5
    name: str = "cylinder"
    contact_surface = False

    def __post_init__(self) -> None:
        self.center = np.asarray(self.center, dtype=float)
