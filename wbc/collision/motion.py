"""How fast the joints can change a pair's distance: the per-dof weights of the collision
model's broad phase (:meth:`wbc.collision.model.CollisionModel.distance_rows`), so that a pair's
last exact distance minus the weighted joint motion since is a lower bound of its distance."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

_CONSTANT_S = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned",
               "JointModelRUBX", "JointModelRUBY", "JointModelRUBZ", "JointModelRevoluteUnboundedUnaligned",
               "JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned",
               "JointModelFreeFlyer", "JointModelPlanar", "JointModelSpherical"}


def motion_weights(model, gm, pairs: np.ndarray, spheres: list[tuple[np.ndarray, float]]) -> np.ndarray:
    """(pairs × nv) weights w with |ḋₖ| ≤ Σⱼ wₖⱼ |q̇ⱼ| in every configuration (q̇ in the joints'
    own frames, as ``pin.difference`` gives it; m per unit of q̇ⱼ).

    A joint moving both geometries of a pair (a common ancestor) moves them as one rigid
    body: ∂d/∂qⱼ = 0. Any other joint j on geometry g's chain moves g's points with the
    velocity S_lin + S_ang × r per unit, r from joint j's origin to the point, so
    wⱼ = ‖S_lin‖ + ‖S_ang‖ Lⱼ with Lⱼ ≥ ‖r‖ for every configuration: the sum of the
    placements' offsets from j to g's joint, plus each prismatic joint's largest travel in
    between, plus ‖placement · c‖ + ρ of g's bounding sphere (c, ρ). Joints whose motion
    subspace S is not constant in their frame get an infinite weight (the pair is computed
    every cycle)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    nv = model.nv
    reach_of_joint = np.zeros(model.njoints)       # a joint's own largest translation
    cols: list[list[tuple[int, float, float]]] = [[] for _ in range(model.njoints)]
    for j in range(1, model.njoints):
        jm = model.joints[j]
        S = (np.asarray(data.joints[j].S).reshape(6, jm.nv) if jm.shortname() in _CONSTANT_S
             else np.full((6, jm.nv), np.inf))
        for c in range(jm.nv):
            cols[j].append((jm.idx_v + c, float(np.linalg.norm(S[:3, c])), float(np.linalg.norm(S[3:, c]))))
        if jm.shortname() in ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"):
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            reach_of_joint[j] = max(abs(float(lo)), abs(float(hi)))
    offset = np.array([np.linalg.norm(model.jointPlacements[j].translation) for j in range(model.njoints)])
    geo = []                                        # per geometry: {joint j: w per v index}
    for g, (centre, rho) in zip(gm.geometryObjects, spheres):
        i = g.parentJoint
        tail = float(np.linalg.norm(g.placement.act(centre))) + rho
        chain = [j for j in model.supports[i] if j > 0]             # root first
        w: dict[int, float] = {}
        for n, j in enumerate(chain):
            L = tail + sum(offset[t] + reach_of_joint[t] for t in chain[n + 1:])
            for idx, lin, ang in cols[j]:
                w[idx] = lin + (ang * L if ang > 0.0 else 0.0)
        geo.append((set(chain), w))
    out = np.zeros((len(pairs), nv))
    for k, (a, b) in enumerate(pairs):
        (sa, wa), (sb, wb) = geo[int(a)], geo[int(b)]
        common = sa & sb
        for j in (sa | sb) - common:
            jm = model.joints[j]
            for idx in range(jm.idx_v, jm.idx_v + jm.nv):
                out[k, idx] = wa.get(idx, 0.0) + wb.get(idx, 0.0)
    return out
