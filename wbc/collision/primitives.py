"""Per-geometry primitives (capsules, spheres, boxes): a cheaper stand-in for a link's convex hull, opt-in.

coal computes a capsule-capsule distance in closed form (segment to segment, minus the radii) and a sphere's
against anything in a few operations, where two hulls take a GJK run (~4-5 µs a pair on Talos). A primitive
**contains** the geometry it replaces (:func:`fit_capsule`), so a distance between primitives is never more than
the hulls' distance: the avoidance stays safe, at the price of the over-approximation (reported per primitive,
``excess``: the largest distance from the primitive's surface to the hull, m).

Where they are: the ``primitives:`` mapping of the robot's collision file ``ROBOT.collisions.yaml`` beside the
robot YAML (the file ``wbc robot collisions`` writes: the self pairs, and with ``--primitives`` the fitted
shapes), keyed by geometry name (pinocchio's ``<link>_<i>``, the names the pairs use)::

    primitives:
      arm_left_2_link_0: {type: capsule, radius: 0.06, length: 0.21, xyz: [0, 0, -0.1], rpy: [0, 0, 0]}
      head_2_link_0: {type: sphere, radius: 0.12, xyz: [0.02, 0, 0.1]}
      rgbd_link_0: {type: box, size: [0.03, 0.18, 0.03]}

``xyz`` (m) and ``rpy`` (rad, URDF order) place the primitive in its **link's** frame (default identity); a
capsule's and a cylinder's axis is its z, ``length`` the distance between the two cap centres (coal's
``Capsule(radius, length)``); a box's ``size`` its full edge lengths. Optional ``excess`` (m) is informative.
Used only by a collision task that asks for them (``geometry: primitives``); the hulls otherwise.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from ..errors import RobotDefinitionError, WbcError
from ..validation.schema import mapping, number, text, vector

__all__ = ["KINDS", "Primitive", "fit_box", "fit_capsule", "fit_primitives", "over_approximation", "read_primitives", "shape_of"]

#: the primitive types and their keys (besides ``type``, ``xyz``, ``rpy``, ``excess``)
KINDS = {"capsule": ("radius", "length"), "cylinder": ("radius", "length"), "sphere": ("radius",), "box": ("size",)}


class Primitive:
    """One primitive: ``kind`` (:data:`KINDS`), its dimensions (m: ``radius``, ``length``, ``size`` (3,)),
    its placement in its link's frame (``pin.SE3``) and the fit's ``excess`` (m, or None).

    Args:
        kind: ``capsule``, ``cylinder``, ``sphere`` or ``box``.
        dims: the kind's dimensions by name (m).
        placement: in the link's frame.
        excess: the largest distance from its surface to the geometry it replaces (m), when known.
    """

    def __init__(self, kind: str, dims: dict[str, Any], placement: pin.SE3, excess: float | None = None) -> None:
        self.kind, self.dims, self.placement, self.excess = kind, dims, placement, excess

    def shape(self):
        """The coal shape."""
        return shape_of(self.kind, self.dims)

    def as_yaml(self) -> dict:
        """The mapping :func:`read_primitives` reads back (floats rounded to 0.1 µm: the fit already has ≥ 1 µm of
        margin, so the rounding keeps it conservative)."""
        out: dict[str, Any] = {"type": self.kind}
        for k, v in self.dims.items():
            out[k] = [round(float(x), 7) for x in v] if np.ndim(v) else round(float(v), 7)
        out["xyz"] = [round(float(x), 7) for x in self.placement.translation]
        out["rpy"] = [round(float(x), 7) for x in pin.rpy.matrixToRpy(self.placement.rotation)]
        if self.excess is not None:
            out["excess"] = round(float(self.excess), 5)
        return out


def shape_of(kind: str, dims: dict[str, Any]):
    """coal's shape for a primitive (:data:`KINDS`; m)."""
    if kind == "capsule":
        return coal.Capsule(float(dims["radius"]), float(dims["length"]))
    if kind == "cylinder":
        return coal.Cylinder(float(dims["radius"]), float(dims["length"]))
    if kind == "sphere":
        return coal.Sphere(float(dims["radius"]))
    size = np.asarray(dims["size"], dtype=float)
    return coal.Box(float(size[0]), float(size[1]), float(size[2]))


def read_primitives(path: Path, geometries: list[str] | None = None) -> dict[str, Primitive]:
    """The ``primitives:`` of a collision file (module docstring), checked: each error names the file, the line, the
    key path (``primitives.NAME.radius``) and the expected value. ``geometries``: the robot's geometry names (a
    primitive for another is an error); None: not checked. {} when the file has no ``primitives:``.

    Args:
        path: the ``ROBOT.collisions.yaml`` file.
        geometries: the robot's geometry names.
    """
    from ..validation.yamlio import read_document

    doc = read_document(path, RobotDefinitionError)
    try:
        return _check(doc.data, geometries)
    except WbcError as e:
        if e.file is None:
            e.file, e.line = path, doc.line(e.key)
        raise


def _check(data: Any, geometries: list[str] | None) -> dict[str, Primitive]:
    err: dict[str, Any] = {"error": RobotDefinitionError}
    if not isinstance(data, dict) or data.get("primitives") is None:
        return {}
    spec = mapping(data["primitives"], "primitives", what="a mapping of geometry name to primitive", **err)
    out = {}
    for name, p in spec.items():
        key = f"primitives.{name}"
        if geometries is not None and name not in geometries:
            from ..validation.schema import suggest

            raise RobotDefinitionError(f"no robot geometry '{name}'{suggest(name, geometries)}; expected one of the "
                                       f"robot's geometry names (<link>_<i>)", key=key)
        p = mapping(p, key, what="a primitive mapping {type, ...}", required=("type",), **err)
        kind = text(p["type"], f"{key}.type", choices=list(KINDS), **err)
        mapping(p, key, allowed=("type", "xyz", "rpy", "excess", *KINDS[kind]), required=KINDS[kind], **err)
        dims: dict[str, Any] = {}
        for d in KINDS[kind]:
            if d == "size":
                dims[d] = vector(p[d], f"{key}.size", 3, unit="m", gt=0, le=10, **err)
            else:
                dims[d] = number(p[d], f"{key}.{d}", unit="m", ge=0 if d == "length" else None,
                                 gt=0 if d == "radius" else None, le=10, **err)
        xyz = vector(p.get("xyz", [0, 0, 0]), f"{key}.xyz", 3, unit="m", **err)
        rpy = vector(p.get("rpy", [0, 0, 0]), f"{key}.rpy", 3, unit="rad", **err)
        excess = number(p["excess"], f"{key}.excess", unit="m", ge=0, **err) if "excess" in p else None
        out[name] = Primitive(kind, dims, pin.SE3(pin.rpy.rpyToMatrix(rpy), xyz), excess)
    return out


def _enclosing_circle(P: np.ndarray) -> tuple[np.ndarray, float]:
    """The smallest circle enclosing the 2-D points P (k × 2): (centre, radius); Welzl's algorithm, iterative,
    on a fixed shuffle (deterministic)."""
    pts = P[np.random.default_rng(0).permutation(len(P))]

    def circle2(a, b):
        c = 0.5 * (a + b)
        return c, float(np.linalg.norm(a - c))

    def circle3(a, b, c):
        ax, ay = a
        bx, by = b
        cx, cy = c
        dd = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        if abs(dd) < 1e-18:
            best = max((circle2(a, b), circle2(a, c), circle2(b, c)), key=lambda t: t[1])
            return best
        ux = ((ax * ax + ay * ay) * (by - cy) + (bx * bx + by * by) * (cy - ay) + (cx * cx + cy * cy) * (ay - by)) / dd
        uy = ((ax * ax + ay * ay) * (cx - bx) + (bx * bx + by * by) * (ax - cx) + (cx * cx + cy * cy) * (bx - ax)) / dd
        u = np.array([ux, uy])
        return u, float(np.linalg.norm(a - u))

    def inside(c, r, p):
        return np.linalg.norm(p - c) <= r * (1 + 1e-12) + 1e-15

    c, r = pts[0].copy(), 0.0
    for i in range(1, len(pts)):
        if inside(c, r, pts[i]):
            continue
        c, r = pts[i].copy(), 0.0
        for j in range(i):
            if inside(c, r, pts[j]):
                continue
            c, r = circle2(pts[i], pts[j])
            for k in range(j):
                if not inside(c, r, pts[k]):
                    c, r = circle3(pts[i], pts[j], pts[k])
    return c, r


def fit_capsule(points: np.ndarray, margin: float = 1e-6) -> tuple[float, float, pin.SE3]:
    """A capsule that contains every point of ``points`` (n × 3, m; so their convex hull too): (radius, length
    between the cap centres, placement in the points' frame, axis z). For each of the points' three principal
    axes: the axis line through the smallest circle enclosing the points' projection across it, then, over radii
    from that circle's to twice it, the caps as low as every point allows (a point at height t and distance ρ from
    the axis is inside when its height past the cap centre is ≤ √(r² − ρ²)); the smallest volume is kept.
    ``margin`` (m) is added to the radius (rounding).

    Args:
        points: the vertices (n × 3, m).
        margin: added to the radius (m).
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    c0 = P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P - c0, full_matrices=False)
    best: tuple[float, float, float, pin.SE3] | None = None
    for a in range(3):
        axis = Vt[a]
        u, w = Vt[(a + 1) % 3], Vt[(a + 2) % 3]
        R = np.column_stack([u, w, axis])
        if np.linalg.det(R) < 0:
            R[:, 0] = -R[:, 0]
        L = (P - c0) @ R                                   # local coordinates (x, y across, z along)
        cc, r0 = _enclosing_circle(L[:, :2])
        rho = np.linalg.norm(L[:, :2] - cc, axis=1)
        t = L[:, 2]
        for r in np.linspace(r0, 2.0 * r0, 81)[:] + 1e-12:
            h = np.sqrt(np.maximum(r * r - rho * rho, 0.0))
            top, bottom = float(np.max(t - h)), float(np.min(t + h))
            length = max(top - bottom, 0.0)
            mid = 0.5 * (top + bottom) if top >= bottom else 0.5 * (top + bottom)
            vol = np.pi * r * r * length + 4.0 / 3.0 * np.pi * r ** 3
            if best is None or vol < best[0]:
                centre = c0 + R @ np.array([cc[0], cc[1], mid])
                best = (vol, float(r), length, pin.SE3(R, centre))
    assert best is not None
    _, r, length, M = best
    return r + margin, length, M


def fit_box(points: np.ndarray, margin: float = 1e-6) -> tuple[np.ndarray, pin.SE3]:
    """A box that contains every point of ``points`` (n × 3, m): (full edge lengths (3,), placement in the points'
    frame), aligned with the points' principal axes, each side grown by ``margin`` (m).

    Args:
        points: the vertices (n × 3, m).
        margin: added to each half side (m).
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    c0 = P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P - c0, full_matrices=False)
    R = Vt.T.copy()
    if np.linalg.det(R) < 0:
        R[:, 0] = -R[:, 0]
    L = (P - c0) @ R
    lo, hi = L.min(axis=0), L.max(axis=0)
    return hi - lo + 2 * margin, pin.SE3(R, c0 + R @ (0.5 * (lo + hi)))


def box_surface(size: np.ndarray, n: int = 9) -> np.ndarray:
    """Points on a box's surface (edge lengths ``size``, centred), an n × n grid per face."""
    h = 0.5 * np.asarray(size, dtype=float)
    g = np.linspace(-1.0, 1.0, n)
    grid_a, grid_b = np.meshgrid(g, g)
    a, b = grid_a.ravel(), grid_b.ravel()
    out = []
    for axis in range(3):
        for s in (-1.0, 1.0):
            f = np.empty((len(a), 3))
            f[:, axis] = s
            f[:, (axis + 1) % 3], f[:, (axis + 2) % 3] = a, b
            out.append(f * h)
    return np.vstack(out)


def capsule_surface(radius: float, length: float, n: int = 24) -> np.ndarray:
    """Points (m × 3) on a capsule's surface (axis z, cap centres at ±length/2), ~n per circle."""
    th = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    out = []
    for z in np.linspace(-length / 2, length / 2, max(2, n // 3)):
        out.append(np.column_stack([radius * np.cos(th), radius * np.sin(th), np.full(n, z)]))
    for s in (-1.0, 1.0):
        for phi in np.linspace(0.0, np.pi / 2, n // 4 + 1)[1:]:
            rr, zz = radius * np.cos(phi), s * (length / 2 + radius * np.sin(phi))
            out.append(np.column_stack([rr * np.cos(th), rr * np.sin(th), np.full(n, zz)]))
    return np.vstack(out)


def over_approximation(hull, shape_points: np.ndarray) -> float:
    """The largest distance (m) from the points ``shape_points`` (a primitive's surface, in the hull's frame) to the
    convex ``hull`` (coal ``Convex``; 0 for a point inside): how much the primitive over-approximates it."""
    tiny = coal.Sphere(1e-9)
    req, worst = coal.DistanceRequest(), 0.0
    for p in shape_points:
        res = coal.DistanceResult()
        d = coal.distance(hull, coal.Transform3s(), tiny, coal.Transform3s(np.eye(3), np.asarray(p, float)), req, res)
        worst = max(worst, float(d))
    return worst


def fit_primitives(cm, max_excess: float) -> tuple[dict[str, Primitive], list[tuple[str, str, float, bool]]]:
    """A primitive per robot geometry of the collision model ``cm`` (hulls, not primitives): of a capsule
    (:func:`fit_capsule`) and a box (:func:`fit_box`) round its hull's vertices, the one that over-approximates the
    hull least (:func:`over_approximation`), placed in its link's frame; kept when that is at most ``max_excess``
    (m). Returns the kept ones by geometry name and, for every geometry, (name, kind, over-approximation in m,
    kept).

    Args:
        cm: a :class:`~wbc.collision.model.CollisionModel` built on the hulls.
        max_excess: the largest over-approximation kept (m).
    """
    from .hulls import hull_vertices, vec3s

    frames = cm.robot.model.frames
    kept: dict[str, Primitive] = {}
    report = []
    for g in cm.geometry_model.geometryObjects[:cm.n_robot]:
        P = hull_vertices(g.geometry)
        hull = g.geometry if isinstance(g.geometry, coal.ConvexBase) else coal.Convex.convexHull(vec3s(P), True, "Qt")
        r, length, Mc = fit_capsule(P)
        size, Mb = fit_box(P)
        cap_excess = over_approximation(hull, capsule_surface(r, length) @ Mc.rotation.T + Mc.translation)
        box_excess = over_approximation(hull, box_surface(size) @ Mb.rotation.T + Mb.translation)
        fits: list[tuple[float, str, dict[str, Any], pin.SE3]] = [
            (cap_excess, "capsule", {"radius": r, "length": length}, Mc), (box_excess, "box", {"size": size}, Mb)]
        excess, kind, dims, M = min(fits, key=lambda f: f[0])
        ok = excess <= max_excess
        report.append((g.name, kind, excess, ok))
        if ok:
            in_link = frames[g.parentFrame].placement.inverse() * g.placement * M
            kept[g.name] = Primitive(kind, dims, in_link, excess)
    return kept, report


def use_primitives(robot, gm: pin.GeometryModel, names: list[str]) -> list[str]:
    """Each robot geometry of ``gm`` named in the robot's collision file's ``primitives:`` becomes that primitive,
    placed in its link's frame (:class:`~wbc.collision.model.CollisionModel` with ``primitives=True``); returns
    the names replaced, sorted. An error if the file has none.

    Args:
        robot: the :class:`~wbc.robot.model.RobotModel`.
        gm: its collision GeometryModel (changed in place).
        names: the robot geometries' names.
    """
    from .pairs import pair_file

    path = pair_file(robot)
    prims = read_primitives(path, names) if path is not None and path.exists() else {}
    if not prims:
        raise RobotDefinitionError(f"robot '{robot.name}' has no collision primitives (expected a "
                                   f"'primitives:' mapping in {path}; `wbc robot collisions "
                                   f"{robot.name} --primitives` fits them)", key="primitives", file=path)
    frames = robot.model.frames
    for g in gm.geometryObjects:
        p = prims.get(g.name)
        if p is not None:
            g.geometry = p.shape()
            g.placement = frames[g.parentFrame].placement * p.placement
    return sorted(prims)
