"""The analytic drift J̇_d q̇ of the distance rows (:mod:`wbc.collision.model`): no coal pass.

The distance between two convex shapes is, near a configuration, the distance between their closest
*features*, each a **core** (a point, a line or a plane) fixed on its body, swept by a radius r (a
sphere's or capsule's; 0 for a hull, a box or a half-space): d = d_c − r₁ − r₂ with d_c the core distance

- point–point ‖y₂ − y₁‖, point–line ‖(I − e eᵀ)(y₂ − y₁)‖, point–plane mᵀ(y_pt − y_pl) (m the plane's
  outward normal), line–line |ĉᵀ(y₂ − y₁)|, ĉ = e₁ × e₂ / ‖e₁ × e₂‖;
- plane–plane and line–plane (a face or edge parallel to the other: d is locally the minimum over
  its vertices) are taken as point–plane at the witness point, as the vertex rows do; near-parallel
  lines (‖e₁ × e₂‖ < 10⁻³) as point–line.

Each core point y and direction e moves with its joint along q̈ = 0: from the joint's twist at the world
origin (v_O, ω) = J q̇ and its acceleration at q̈ = 0 (a_O, α) = J̇ q̇ (pinocchio's world-frame Jacobians
and their time variation), ẏ = v_O + ω × y, ÿ = a_O + α × y + ω × ẏ, ė = ω × e, ë = α × e + ω × ė. Then
d̈ = [d_c(y(h), e(h)) − 2 d_c + d_c(y(−h), e(−h))] / h² on the second-order Taylor paths y(±h), e(±h)
(normalised), h = 1 ms: exact to O(h²) for the local model, which holds the terms the witness-point drift
(:func:`wbc.collision.drift.rigid_drift`) leaves out, the normal's turn and the witness points sliding
over the other body (e.g. a vertex against a rotating face: nᵀ(a₂ − a₁) + 2 (ω₂ × n)ᵀ(v₂ − v₁) −
d ‖ω₂ × n‖²; a point round a sphere of radius R: nᵀ(a₂ − a₁) + ‖(I − n nᵀ)(v₂ − v₁)‖² / (R + d)).

Features: a hull's (or box's) closest feature starts from its vertex extremal along the outward
direction (±n), found by a hill climb on the hull's vertex graph from the last cycle's (a linear function
on a convex polytope has no local maximum but the global one); its neighbours within ``FEATURE_TOL`` of
its support value make it an edge (one) or a face (two or more); the core point is the witness point.
A sphere is a point (its centre p − r n), a capsule a line (its axis, when n is normal to it) or a point
(a cap's centre), a half-space a plane. Pairs it cannot model (a cylinder, a cone, a mesh; d <
``MIN_DISTANCE``) take the exact drift
(:func:`wbc.collision.drift.curvature_drift`). At a feature switch the drift jumps (the exact second
difference spreads the switch over ±10 ms instead).
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from ..robot.held_views import joint_rotations
from .drift import curvature_drift
from .feature_kernel import CAPSULE, HALFSPACE, HULL, SPHERE, UNSUPPORTED, feature_drift, rows_and_drift

__all__ = ["FeatureDrift"]

#: m: a hull neighbour whose support value along the normal is within this of the extremal vertex's is on the
#: closest feature
FEATURE_TOL = 1e-5
#: m: below this distance the local model's point-to-point and line-to-line forms are not smooth: exact drift
MIN_DISTANCE = 1e-4
#: s: the Taylor paths' step
STEP = 1e-3


class FeatureDrift:
    """The analytic drift of a :class:`~wbc.collision.model.CollisionModel`'s pairs (module docstring).

    Args:
        cm: the collision model (its geometries are read once here).
    """

    def __init__(self, cm) -> None:
        self.cm = cm
        gm = cm.geometry_model
        n = gm.ngeoms
        self.kind = np.full(n, UNSUPPORTED, dtype=np.int64)
        self.radius = np.zeros(n)
        self.ends = np.zeros((n, 2, 3))          # sphere centre / capsule ends, in the joint's frame
        self.offset = np.zeros(n, dtype=np.int64)
        self.count = np.zeros(n, dtype=np.int64)
        verts, nbrs = [], []
        total = 0
        for i, go in enumerate(gm.geometryObjects):
            g, M = go.geometry, go.placement
            R, t = M.rotation, M.translation
            if isinstance(g, (coal.ConvexBase, coal.Box)):
                if isinstance(g, coal.Box):
                    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
                    P = signs * np.asarray(g.halfSide, dtype=float)
                    nb = [[j for j in range(8) if np.count_nonzero(signs[j] != signs[c]) == 1] for c in range(8)]
                else:
                    P = np.asarray(g.points(), dtype=float).reshape(-1, 3)
                    nb = [list(g.neighbors(c)) for c in range(len(P))]
                self.kind[i] = HULL
                self.offset[i], self.count[i] = total, len(P)
                verts.append(P @ R.T + t)
                nbrs.extend([[total + j for j in row] for row in nb])
                total += len(P)
            elif isinstance(g, coal.Sphere):
                self.kind[i] = SPHERE
                self.radius[i] = g.radius
                self.ends[i] = t
            elif isinstance(g, coal.Capsule):
                self.kind[i] = CAPSULE
                self.radius[i] = g.radius
                self.ends[i, 0] = t - g.halfLength * R[:, 2]
                self.ends[i, 1] = t + g.halfLength * R[:, 2]
            elif isinstance(g, coal.Halfspace):
                self.kind[i] = HALFSPACE
        #: every hull's vertices (and a box's corners) in its joint's frame, stacked
        self.vertices = np.concatenate(verts) if verts else np.zeros((1, 3))
        width = max((len(r) for r in nbrs), default=1)
        #: padded neighbour lists (indices into :attr:`vertices`; −1: none)
        self.neighbours = np.full((max(len(nbrs), 1), width), -1, dtype=np.int64)
        for j, row in enumerate(nbrs):
            self.neighbours[j, :len(row)] = row
        #: each pair's last extremal vertex per side (local index), where the next hill climb starts
        self.hints = np.zeros((len(cm.pairs), 2), dtype=np.int64)
        #: how many of the last call's pairs took the exact drift
        self.fallback = 0
        # the joints' world rotations, one (njoints × 3 × 3) view on ``cm.fd_data``'s own storage that follows every
        # later forward kinematics of it (:func:`wbc.robot.held_views.joint_rotations`; checked in the tests); None
        # where pinocchio's storage is not laid out as one (then stacked per call). The translations are not needed
        # (the cores are found from the witness points).
        self._rotations = joint_rotations(cm.fd_data)
        # ``cm.fd_data``'s J and J̇ (6 × nv), as views on its own storage that every later
        # ``computeJointJacobiansTimeVariation`` of it refills (checked in the tests): each read through the bindings
        # makes a new view (~1 µs); None where they are copies (then read per call)
        J, dJ = cm.fd_data.J, cm.fd_data.dJ
        self._jacobians = None if J.flags.owndata or dJ.flags.owndata else (J, dJ)

    def _time_variation(self, robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """pinocchio's J̇ at the robot's state (``computeJointJacobiansTimeVariation`` on the model's own data), and
        the joints' rotations R (njoints × 3 × 3), J and J̇ (6 × nv, world-aligned) the kernels read."""
        data = self.cm.fd_data
        pin.computeJointJacobiansTimeVariation(robot.model, data, robot.q, robot.v)
        R = self._rotations
        if R is None:
            R = np.array([data.oMi[j].rotation for j in range(robot.model.njoints)])
        J, dJ = (data.J, data.dJ) if self._jacobians is None else self._jacobians
        return R, J, dJ

    def drift(self, robot, ks: np.ndarray, d: np.ndarray, P: np.ndarray, NN: np.ndarray, jid: np.ndarray,
              geoms: np.ndarray) -> np.ndarray:
        """J̇_d q̇ (k,; m/s²) of the pairs ``ks`` at the robot's state, from their witness points and normals, each side
        first sides then second (:func:`wbc.collision.row_kernels.near_rows`).

        Args:
            robot: the robot at the cycle's state (q, q̇).
            ks: the pairs (k,; indices into ``cm.pairs``).
            d: their distances (k,; m).
            P: the witness points (2k × 3, m, world): [p₁; p₂].
            NN: each side's normal (2k × 3): [−n; n], n the unit normal from the first geometry to the second.
            jid: each side's joint (2k,).
            geoms: each side's geometry (2k,).
        """
        cm = self.cm
        if not len(ks):
            return np.zeros(0)
        v = robot.v
        R, J, dJ = self._time_variation(robot)
        out, bad, self.fallback = feature_drift(ks, geoms, d, P, NN, R, J, dJ, cm.support, jid, v, self.kind,
                                                self.radius, self.ends, self.vertices, self.neighbours, self.offset,
                                                self.count, self.hints, FEATURE_TOL, MIN_DISTANCE, STEP)
        if self.fallback:
            out[bad] = curvature_drift(cm, robot, ks[bad])
        return out

    def held_rows(self, robot, table: np.ndarray, near: np.ndarray, influence: float) -> tuple:
        """The cycle's rows read from the held result table after coal and their drift, one compiled call
        (:func:`wbc.collision.feature_kernel.rows_and_drift`): what ``held_near_rows`` then :meth:`drift` give, bit for
        bit, as (ks, d, P, NN, coef, jid, drift) (:func:`wbc.collision.row_kernels.near_rows`' fields; drift (m,) m/s²).

        Args:
            robot: the robot at the cycle's state (q, q̇).
            table: the held (pairs × 7) table of the cycle's GeometryData (:mod:`wbc.collision.result_table`).
            near: the pairs coal computed (c,), the broad phase's references ``d0``, ``moved`` updated here.
            influence: the influence distance (m).
        """
        cm = self.cm
        v = robot.v
        R, J, dJ = self._time_variation(robot)
        d0, moved = cm.broad_references()
        ks, d, P, NN, coef, jid, out, self.fallback = rows_and_drift(
            table, near, influence, d0, moved, cm.pairs, cm.joint_of, R, J, dJ, cm.support, v, self.kind,
            self.radius, self.ends, self.vertices, self.neighbours, self.offset, self.count, self.hints, FEATURE_TOL,
            MIN_DISTANCE, STEP)
        if self.fallback:                   # the pairs the model does not apply to: NaN (rows_and_drift)
            bad = np.isnan(out)
            out[bad] = curvature_drift(cm, robot, ks[bad])
        return ks, d, P, NN, coef, jid, out
