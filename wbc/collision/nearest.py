"""The collision model's queries over every pair by bounding spheres (the monitor's), bound as methods of
:class:`wbc.collision.model.CollisionModel`: the pairs' lower bounds from their bounding spheres (centre c, radius ρ in the
joint's frame: ‖c₁ − c₂‖ − ρ₁ − ρ₂ ≤ d; a plane: its signed distance to c minus ρ) and the smallest exact distances
found in the order of those bounds. Units: m.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["bounds_at", "broad_gaps", "smallest_distances"]


def broad_gaps(cm, W: np.ndarray) -> np.ndarray:
    """The bounding spheres' lower bound of each pair's distance (m), from the spheres' world centres ``W`` (ngeoms × 3, m)
    of the :class:`~wbc.collision.model.CollisionModel` ``cm``."""
    diff = W[cm._pa] - W[cm._pb]
    gaps = np.sqrt(np.einsum("ka,ka->k", diff, diff)) - cm._rsum
    for k in cm._plane_pairs:
        i, j = cm.pairs[k]
        (n, off), c, r = (cm.planes[j], W[i], cm.radii[i]) if j in cm.planes else (cm.planes[i], W[j],
                                                                                          cm.radii[j])
        gaps[k] = n @ c - off - r
    return gaps


def smallest_distances(cm, q: np.ndarray, count: int, data: pin.Data,
                       geometry_data: pin.GeometryData) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` smallest distances over **all** monitored pairs at ``q`` (m), exactly, and their pair indices, nearest
    first. Exact distances are computed in order of the broad phase's lower bound (bounding spheres: ‖c₁ − c₂‖ − ρ₁ −
    ρ₂ ≤ d, also in penetration) until that bound exceeds the ``count``-th smallest distance found: no pair left out
    can be nearer, so the result is the one all pairs would give, at a fraction of the cost.

    Args:
        cm: the :class:`~wbc.collision.model.CollisionModel`.
        q: the configuration (nq).
        count: how many (≥ 1).
        data: pinocchio data for the placements.
        geometry_data: where the results go (:meth:`new_geometry_data`).
    """
    gd = geometry_data
    bound = cm.bounds_at(q, data, gd)
    order = np.argsort(bound)
    best_d: list[float] = []
    best_k: list[int] = []
    start, batch = 0, max(8, count)
    while start < len(order):
        if len(best_d) >= count and bound[order[start]] > sorted(best_d)[count - 1]:
            break
        ks = order[start:start + batch]
        best_d.extend(r.min_distance for r in cm.pair_results(ks, gd, cm._check_map))
        best_k.extend(ks.tolist())
        start += batch
        batch *= 2
    d, k = np.array(best_d), np.array(best_k, dtype=np.int64)
    first = np.argsort(d)[:count]
    return d[first], k[first]


def bounds_at(cm, q: np.ndarray, data: pin.Data, gd: pin.GeometryData) -> np.ndarray:
    """The placements at ``q`` (in ``data``, ``gd``) and every pair's bounding-sphere lower bound (m) of the collision
    model ``cm``."""
    model = cm.robot.model
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, cm.geometry_model, gd)
    H = np.array([M.homogeneous for M in gd.oMg])
    return cm._broad_gaps(np.einsum("kab,kb->ka", H[:, :3, :3], cm.centres) + H[:, :3, 3])
