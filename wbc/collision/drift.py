"""The drift J̇_d q̇ of the distance rows (:mod:`wbc.collision.model`), two ways.

- :func:`rigid_drift`: the witness points' rigid-body drift nᵀ(a_p₂ − a_p₁), a_p the classical
  acceleration at q̈ = 0 of the point of the geometry's joint (one product; blind to the
  surfaces' curvature and the normal's turn);
- :func:`curvature_drift`: the exact second difference of the distance along q̈ = 0 (three
  more coal passes; the default, ``CollisionModel.exact_drift``);
- :func:`switch_jump`: the exact drift, the jump of ḋ at a closest-feature switch ahead and the pieces' curvature
  (the same three coal passes), for the collision task's ``drift: switching`` (:mod:`wbc.tasks.collision_avoidance`).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["cross_rows", "curvature_drift", "point_drift", "rigid_drift", "switch_jump"]


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
    d0, ahead, behind = _three_distances(cm, robot, ks)
    eps = cm.drift_step
    return (-2.0 * d0 + ahead + behind) / (eps * eps)


def _three_distances(cm, robot, ks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """d(q), d(q ⊕ εv), d(q ⊖ εv) of the pairs ``ks`` (m; ε = ``cm.drift_step`` s), three coal passes on the model's
    own finite-difference data."""
    eps = cm.drift_step
    d0, dp, dm = _distances(cm, robot, ks, (0.0, eps, -eps))
    return d0, dp, dm


def _distances(cm, robot, ks: np.ndarray, steps: tuple[float, ...]) -> list[np.ndarray]:
    """d(q ⊕ s v) of the pairs ``ks`` (m) for each step s (s) of ``steps``, one coal pass each on the model's own
    finite-difference data (s = 0: d(q))."""
    model, gm, gd, data = robot.model, cm.geometry_model, cm.fd_geometry_data, cm.fd_data
    ds = []
    for step in steps:
        q = robot.q if step == 0.0 else pin.integrate(model, robot.q, step * robot.v)
        pin.forwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, gm, gd)
        ds.append(cm.pair_distances(ks, gd))
    return ds


def rigid_drift(cm, robot, ks: np.ndarray, P1: np.ndarray, P2: np.ndarray, N: np.ndarray) -> np.ndarray:
    """The witness points' rigid-body drift nᵀ(a_p₂ − a_p₁) of the pairs ``ks`` (k,; m/s²): a_p the classical
    acceleration at q̈ = 0 of the point p of its geometry's joint, world-aligned. With the joint's spatial twist at the
    world origin V = J q̇ = (v_O, ω) and its spatial acceleration at q̈ = 0, J̇ q̇ = (a'_O, α) (pinocchio's world-frame
    joint Jacobians and their time variation), a_p = a'_O + α × p + ω × v_p, v_p = v_O + ω × p, so
    nᵀ a_p = [n; p × n]ᵀ (J̇ q̇) + nᵀ (ω × v_p): one (2k × 6)(6 × nv) product like J_d's, each row masked by its
    joint's supporting chain (zero on the universe). Blind to the normal's turn and the witness points sliding
    (:func:`curvature_drift` holds those).

    Args:
        cm: the :class:`~wbc.collision.model.CollisionModel` (its ``fd_data`` gets the time variation).
        robot: the robot at the cycle's state (q, q̇).
        ks: the pairs (k,).
        P1: first witness points (k × 3, m, world).
        P2: second witness points (k × 3).
        N: unit normals from the first geometry to the second (k × 3).
    """
    m = len(ks)
    if not m:
        return np.zeros(0)
    jid = cm.joint_of[cm.pairs[ks].T.ravel()]
    out = point_drift(cm, robot, jid, np.concatenate([P1, P2]), np.concatenate([-N, N]))
    return out[:m] + out[m:]


def point_drift(cm, robot, jid: np.ndarray, P: np.ndarray, N: np.ndarray) -> np.ndarray:
    """nᵀ a_p (k,; m/s²) of points p fixed on joints ``jid`` (k,), directions N (k × 3), at q̈ = 0:
    a_p the classical acceleration of p, world-aligned, zero on the universe (joint 0). The formula
    of :func:`rigid_drift` (which sums it over each pair's two witness points, n and −n), for any
    points: the collision task's vertex rows take it for a hull vertex and the other witness point.

    Args:
        cm: the :class:`~wbc.collision.model.CollisionModel` (its ``fd_data`` gets the time variation).
        robot: the robot at the cycle's state (q, q̇).
        jid: each point's joint (k,).
        P: the points (k × 3, m, world).
        N: the directions (k × 3).
    """
    if not len(jid):
        return np.zeros(0)
    data, v = cm.fd_data, robot.v
    pin.computeJointJacobiansTimeVariation(robot.model, data, robot.q, v)
    S = cm.support[jid]                                               # (k × nv)
    coef = np.concatenate([N, cross_rows(P, N)], axis=1)              # (k × 6)
    bias = ((coef @ data.dJ) * S) @ v                                 # [n; p × n]ᵀ (J̇ q̇)
    twist = S @ (data.J * v).T                                        # (k × 6): each row's J_j q̇
    w = twist[:, 3:]
    vp = twist[:, :3] + cross_rows(w, P)
    return bias + np.einsum("ka,ka->k", N, cross_rows(w, vp))


def switch_jump(cm, robot, ks: np.ndarray, d_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the exact drift, :func:`curvature_drift` (k,; m/s²); the jump of ḋ (k,; m/s, ≤ 0) at switches of the closest
    features within the next ε (``cm.drift_step``) along q̈ = 0; the pieces' curvature a (k,; m/s²)), from the same
    three coal passes, four more at ±s, ±2s (s = ``cm.switch_step``, None: none) and ḋ = J_d q̇ (``d_dot``): the
    one-sided differences a±(σ) = ±2 [d(q ⊕ ±σv) − d(q) ∓ ḋ σ] / σ² for σ = ε (their mean is the exact drift) and
    σ = s, the second differences c± = [d(q) − 2 d(q ⊕ ±sv) + d(q ⊕ ±2sv)] / s² centred at ±s, a = the largest of
    these six and Δ̂ = −ε/2 · max(0, a − a₊(ε)).

    Between hulls the distance is the minimum over feature pairs: where another pair becomes the closest, ḋ drops by
    Δ < 0 (a concave kink; a faceted round surface sliding past another is a staircase of them, every 0.5-5 ms at
    0.5 m/s on Talos). Since d is never above the distance f of the features closest at a point x (equal at x), a
    difference whose base point (the one-sided ones: q, with f's slope ḋ) or middle point (c±: q ⊕ ±sv) is x is at most
    f'' somewhere in its interval: a switch inside it only lowers it (a one-sided one by 2 |Δ| (σ − |τ|)/σ² for a
    switch at τ), so a is the curvature of the features closest within 2s of q (to the differences' own O(σ d⃛)),
    never above it. With ε alone, switches on both sides of the ±10 ms window (Talos's upper arm past the torso:
    a₊(ε), a₋(ε) = −4 to −7 m/s² where the pieces curve at +1 to +2.6) lower both; the short ones are clean unless
    switches fall inside (0, 2s) and (−2s, 0) both, and c± also where a switch is at q itself (ḋ then the old
    features' slope: a±(s) ≈ 2Δ/s, −40 to −80 m/s², measured in MuJoCo). With the switches ahead at τᵢ ∈ [0, ε),
    a − a₊(ε) = (2/ε) Σ |Δᵢ| (ε − τᵢ)/ε, so Δ̂ = Σ Δᵢ (ε − τᵢ)/ε, which tends to Δ as a switch nears; switches already
    passed are in ḋ and count for nothing; a smooth distance gives a = d̈ + ε |d⃛|/3, Δ̂ = O(ε² d⃛). Without s this is
    max(a₊(ε), a₋(ε)) and Δ̂ = −ε/2 · max(0, a₋(ε) − a₊(ε)), bit for bit.

    Args:
        cm: the :class:`~wbc.collision.model.CollisionModel`.
        robot: the robot at the cycle's state (q, q̇).
        ks: the pairs (indices into ``cm.pairs``).
        d_dot: their ḋ = J_d q̇ (k,; m/s).
    """
    d0, dp, dm = _three_distances(cm, robot, ks)
    eps = cm.drift_step
    central = (-2.0 * d0 + dp + dm) / (eps * eps)
    ahead = 2.0 * (dp - d0 - d_dot * eps) / (eps * eps)
    behind = 2.0 * (dm - d0 + d_dot * eps) / (eps * eps)
    a = np.maximum(ahead, behind)
    s = cm.switch_step
    if s:
        p1, m1, p2, m2 = _distances(cm, robot, ks, (s, -s, 2.0 * s, -2.0 * s))
        ss = s * s
        short = (2.0 * (p1 - d0 - d_dot * s) / ss, 2.0 * (m1 - d0 + d_dot * s) / ss,
                 (d0 - 2.0 * p1 + p2) / ss, (d0 - 2.0 * m1 + m2) / ss)
        a = np.maximum(a, np.max(short, axis=0))
    return central, -0.5 * eps * np.maximum(a - ahead, 0.0), a
