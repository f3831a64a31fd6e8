"""The drift J̇_d q̇ of the distance rows (:mod:`wbc.collision.model`), two ways.

- :func:`point_drift`: the witness points' rigid-body drift nᵀ(a_p₂ − a_p₁), a_p the classical
  acceleration at q̈ = 0 of the point of the geometry's joint (cheap; blind to the surfaces'
  curvature and the normal's turn);
- :func:`curvature_drift`: the exact second difference of the distance along q̈ = 0 (three
  more coal passes; the default, ``CollisionModel.exact_drift``).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["cross_rows", "curvature_drift", "point_drift"]


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of (k × 3) arrays (numpy's ``cross`` costs ~10 µs of overhead a call)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


def curvature_drift(cm, robot, ks: np.ndarray) -> np.ndarray:
    """The exact J̇_d q̇ of the pairs ``ks`` of the collision model ``cm`` (m/s²): the second derivative of their
    distance along q̈ = 0, d̈ = [d(q ⊕ εv) − 2 d(q) + d(q ⊖ εv)] / ε² (ε = ``cm.drift_step`` s, coal at 1e-8 m, all
    three on the model's own finite-difference data: d(q) taken from the cycle's exact phase instead moved
    ``tiago_table_reach``'s closest approach by 0.6-0.75 mm, to 18.96 mm < d_s − 1 mm, both with the cycle's pass at
    coal's default 1e-6 m and at 1e-8 m, although the two runs of d(q) agree to 5e-9 m on ``talos_hands_cross``: not
    understood, so not shared), which holds the terms the witness-point drift leaves out: the normal's turn and the
    witness points sliding over curved or rotating surfaces (a hand hull sliding round a sphere: −1.6 m/s² where the
    rigid drift says +0.14, which the damper turned into a steady violation of 1.75/ω² = 3.5 mm). ε = 10 ms, not
    less: between two hulls the distance is C¹ but not C² (the closest features switch), and a 1 ms difference turned
    each switch into a −12 to −34 m/s² spike (Talos's torso against an upper arm) that made level 0 infeasible; over
    ±10 ms the switch is spread ten times thinner, and a smooth curvature (radius ≥ 5 cm at ≤ 0.5 m/s) is still
    exact to a few %.

    Args:
        cm: the :class:`~wbc.collision.model.CollisionModel`.
        robot: the robot at the cycle's state (q, q̇).
        ks: the pairs (indices into ``cm.pairs``).
    """
    model, gm, gd, data = robot.model, cm.geometry_model, cm.fd_geometry_data, cm.fd_data
    eps = cm.drift_step
    out = np.zeros(len(ks))
    for step, w in ((0.0, -2.0), (eps, 1.0), (-eps, 1.0)):
        q = robot.q if step == 0.0 else pin.integrate(model, robot.q, step * robot.v)
        pin.forwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, gm, gd)
        out += w * np.array([r.min_distance for r in cm.pair_results(ks, gd)])
    return out / (eps * eps)


def point_drift(data, jid: np.ndarray, P: np.ndarray, N: np.ndarray) -> np.ndarray:
    """nᵀ a_p (k,) of the points P on joints ``jid`` at q̈ = 0: a_p = a_o + α × r + ω × (ω × r), r = p − o_j, all
    world-aligned (m/s²); zero on the universe (joint 0).

    Args:
        data: pinocchio data with the cycle's placements, velocities and accelerations at q̈ = 0.
        jid: each point's joint (k,).
        P: the points (k × 3, m, world).
        N: the directions (k × 3, unit, world).
    """
    joints, inv = np.unique(jid, return_inverse=True)
    u = len(joints)
    Ru = np.empty((u, 3, 3))
    ou = np.empty((u, 3))
    vau = np.empty((u, 4, 3))
    for i, j in enumerate(joints):  # once per joint: the per-joint quantities pinocchio holds
        M = data.oMi[int(j)]
        Ru[i], ou[i] = M.rotation, M.translation
        v, acc = data.v[int(j)], data.a[int(j)]
        vau[i] = (v.linear, v.angular, acc.linear, acc.angular)
    R, o, va = Ru[inv], ou[inv], vau[inv]
    world = np.einsum("kab,knb->kna", R, va)                       # rotated to the world
    v_o, w, a_o, alpha = world[:, 0], world[:, 1], world[:, 2], world[:, 3]
    r = P - o
    a_p = a_o + cross_rows(w, v_o) + cross_rows(alpha, r) + cross_rows(w, cross_rows(w, r))
    out = np.einsum("ka,ka->k", N, a_p)
    out[jid == 0] = 0.0
    return out
