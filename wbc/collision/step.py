"""Conservative advancement of one commanded step: the largest fraction α ∈ [0, 1] of a step
δ (q⁺(α) = q ⊕ α δ) that keeps every monitored pair at least d_s apart.

The velocity damper's rows, and their re-linearisation at the command, only hold pairs
already within the influence distance d_i, and only to first order: a long step (an IK's
Gauss–Newton step of 1 rad) can carry a link from beyond d_i into another. The last check of
a velocity command is therefore exact and covers every pair: at q⁺(α), each pair whose
broad-phase bound cannot prove d ≥ d_s gets coal's exact distance
(:func:`distances_below`), and α is accepted when every
such pair keeps

    d_k(q⁺(α)) ≥ d_s − tol             if d_k(q) ≥ d_s − tol,
    d_k(q⁺(α)) ≥ d_s − slack           if d_s − slack ≤ d_k(q) < d_s − tol,
    d_k(q⁺(α)) ≥ d_k(q)                otherwise

(a pair already below d_s − slack must not get nearer, else a long run of shortened steps
could lose a little at each; ``slack`` = :data:`STEP_SLACK` = 0.5 mm, so no pair ever lands
below d_s − 0.5 mm that was not there already). The band between d_s − slack and d_s − tol
is there because the distance between hulls has kinks (two features tied): at a kink the
rows' J_d, of one feature, can promise ḋ ≥ 0 while the other feature nears, so that every
α > 0 of the direction brings a pair just below d_s nearer; with the floor at d_k(q), the
step check then refused the whole command, the same at the next cycle, and a velocity IK
(``benchmarks/ik_peers.py --unreachable``) stopped for good 9.8 mm from d_s = 10 mm. α = 1 is tried first (one broad phase
and a few exact pairs: the collision-free cycle's whole cost); when it fails, α is bisected
between the last accepted and the last refused value. Scaling the whole step keeps each
task's direction, so the hierarchy's choice is kept and no level is traded for the
collision constraint. Only the end point is checked: at a control period's step (1 ms) the
path between is a fraction of a millimetre; at an IK's long step a thin link could in
principle pass through a thin one and out (not seen on the bundled robots' hulls).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["STEP_CHECKS", "STEP_SLACK", "STEP_TOL", "distances_below", "step_scale"]

#: bisection checks after α = 1 fails (the returned α is within 2⁻ⁿ of the largest safe one)
STEP_CHECKS = 6
#: how far (m) below its floor a pair may land before the step is shortened
STEP_TOL = 1e-4
#: how far (m) below d_s a pair already within ``STEP_TOL`` … this of d_s may land (module docstring)
STEP_SLACK = 5e-4


def distances_below(model, q: np.ndarray, floor: float, data: pin.Data,
                    geometry_data, cmap: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(pair indices, exact distances in m) at ``q`` of every pair of ``model`` the broad phase
    cannot prove at least ``floor`` apart (bounding spheres: ‖c₁ − c₂‖ − ρ₁ − ρ₂ ≤ d): every pair
    closer than ``floor`` is among them.

    Args:
        model: the :class:`~wbc.collision.model.CollisionModel`.
        q: the configuration (nq).
        floor: the distance (m) to prove.
        data: pinocchio data for the placements.
        geometry_data: where the results go (its :meth:`new_geometry_data`).
        cmap: the active-pair map to fill (ngeoms × ngeoms bool, reused across calls); None: a
            new one.
    """
    ks = np.flatnonzero(model.bounds_at(q, data, geometry_data) < floor)
    if not len(ks):
        return ks, np.empty(0)
    if cmap is None:
        n = model.geometry_model.ngeoms
        cmap = np.zeros((n, n), dtype=bool)
    return ks, model.pair_distances(ks, geometry_data, cmap)


def step_scale(model, q: np.ndarray, step: np.ndarray, safety: float, data: pin.Data, geometry_data,
               checks: int = STEP_CHECKS, tol: float = STEP_TOL) -> tuple[float, str | None, float]:
    """The largest α ∈ [0, 1] found (module docstring), the pair that shortened it (or None) and
    that pair's distance at the full step (m; +inf when α = 1).

    Args:
        model: the :class:`~wbc.collision.model.CollisionModel`.
        q: the configuration the step starts from (nq).
        step: the tangent step δ = q̇ dt (nv; rad, m).
        safety: d_s (m).
        data: pinocchio data of the robot's model (the caller's own).
        geometry_data: a geometry data of ``model`` (:meth:`~wbc.collision.model.CollisionModel.new_geometry_data`).
        checks: bisection checks after α = 1 fails; more are taken (up to 3 × ``checks``)
            while no α > 0 has been accepted.
        tol: how far (m) below its floor a pair may land.
    """
    rm = model.robot.model
    n = model.geometry_model.ngeoms
    cmap = np.zeros((n, n), dtype=bool)          # one map for this step's checks
    ks, d = distances_below(model, pin.integrate(rm, q, step), safety, data, geometry_data, cmap)
    if not len(ks) or d.min() >= safety - tol:
        return 1.0, None, np.inf
    below0, d0 = distances_below(model, q, safety, data, geometry_data, cmap)
    floors = dict(zip(below0.tolist(), np.where(d0 >= safety - tol, safety - tol,
                                                np.where(d0 >= safety - STEP_SLACK, safety - STEP_SLACK, d0)).tolist()))

    def worst(ks: np.ndarray, d: np.ndarray) -> tuple[int, float]:
        """The pair furthest below its floor and by how much (m; < 0: refused)."""
        gaps = d - np.array([floors.get(k, safety - tol) for k in ks.tolist()]) if len(ks) else np.zeros(0)
        if not len(gaps):
            return -1, np.inf
        i = int(np.argmin(gaps))
        return int(ks[i]), float(gaps[i])

    k_full, gap = worst(ks, d)
    if gap >= 0.0:
        return 1.0, None, np.inf
    d_full = float(d[list(ks).index(k_full)])
    lo, hi, n = 0.0, 1.0, 0
    while n < checks or (lo == 0.0 and n < 3 * checks):
        a = 0.5 * (lo + hi)
        ks, d = distances_below(model, pin.integrate(rm, q, a * step), safety, data, geometry_data, cmap)
        if worst(ks, d)[1] >= 0.0:
            lo = a
        else:
            hi = a
        n += 1
    return lo, model.pair_name(k_full), d_full
