"""The compiled PGS's sweep (wbc.sim.pgs.pgs_solve) with its step sizes divided out once and the
residuals left off after the first contact above the tolerance (#26): the same sweeps, the same
converged flag, the same impulses and contact velocities, bit for bit, as the former kernel
(copied below as it was), on random problems and on a simulated Talos's own contact steps."""

from __future__ import annotations

import numba as nb
import numpy as np
import pinocchio as pin

import wbc
from wbc.sim import contact_rows as cr
from wbc.sim.environment import ground
from wbc.sim.pgs import EPS_DIAGONAL, _dual_cone_residual, pgs_solve
from wbc.sim.simulator import PGS_ABSOLUTE_PRECISION, PGS_MAX_ITERATIONS, PGS_RELATIVE_PRECISION, Simulator


@nb.njit(cache=False)
def _former_pgs(G, g, mus, lam, over_relax, max_sweeps, abs_tol, rel_tol, Gs, lam_prev, sigma):
    """The PGS of the module docstring, in place: ``lam`` (3n) the warm start on entry and
    the impulses on return; ``Gs`` (3n × 3n), ``lam_prev`` and ``sigma`` (3n) workspaces
    (``sigma`` holds each contact's last velocity G λ + g). Returns (sweeps, converged)."""
    n = lam.shape[0]
    nc = n // 3
    for i in range(n):
        for j in range(n):
            Gs[i, j] = 0.5 * (G[i, j] + G[j, i])
    prev_norm = 0.0
    for i in range(n):
        prev_norm = max(prev_norm, abs(lam[i]))
    sweeps = 0
    converged = False
    while sweeps < max_sweeps:
        sweeps += 1
        lam_prev[:] = lam
        complementarity = 0.0
        dual = 0.0
        for c in range(nc):
            r = 3 * c
            mu = mus[c]
            s0 = g[r]
            s1 = g[r + 1]
            s2 = g[r + 2]
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            for j in range(n):
                x = lam[j]
                a0 += Gs[r, j] * x
                a1 += Gs[r + 1, j] * x
                a2 += Gs[r + 2, j] * x
            s0 += a0
            s1 += a1
            s2 += a2
            # normal
            fz_prev = lam[r + 2]
            fz = fz_prev - (over_relax / max(EPS_DIAGONAL, Gs[r + 2, r + 2])) * s2
            if fz < 0.0:
                fz = 0.0
            lam[r + 2] = fz
            dz = fz - fz_prev
            s0 += Gs[r, r + 2] * dz
            s1 += Gs[r + 1, r + 2] * dz
            s2 += Gs[r + 2, r + 2] * dz
            # tangent, projected on the disc of radius μ λ_n
            dmin = max(EPS_DIAGONAL, min(Gs[r, r], Gs[r + 1, r + 1]))
            t0_prev = lam[r]
            t1_prev = lam[r + 1]
            step = over_relax / dmin
            t0 = t0_prev - step * s0
            t1 = t1_prev - step * s1
            tn = np.sqrt(t0 * t0 + t1 * t1)
            mu_fz = mu * fz
            if tn > mu_fz:
                k = mu_fz / tn
                t0 *= k
                t1 *= k
            lam[r] = t0
            lam[r + 1] = t1
            d0 = t0 - t0_prev
            d1 = t1 - t1_prev
            s0 += Gs[r, r] * d0 + Gs[r, r + 1] * d1
            s1 += Gs[r + 1, r] * d0 + Gs[r + 1, r + 1] * d1
            s2 += Gs[r + 2, r] * d0 + Gs[r + 2, r + 1] * d1
            sigma[r] = s0
            sigma[r + 1] = s1
            sigma[r + 2] = s2
            # residuals with the De Saxcé correction
            c2 = s2 + mu * np.sqrt(s0 * s0 + s1 * s1)
            complementarity = max(complementarity, abs(lam[r] * s0 + lam[r + 1] * s1 + fz * c2))
            dual = max(dual, _dual_cone_residual(mu, s0, s1, c2))
        absolute = dual <= abs_tol and complementarity <= abs_tol
        proximal = 0.0
        norm = 0.0
        for i in range(n):
            proximal = max(proximal, abs(lam[i] - lam_prev[i]))
            norm = max(norm, abs(lam[i]))
        if absolute or proximal <= rel_tol * max(norm, prev_norm):
            converged = True
            break
        prev_norm = norm
    return sweeps, converged


def _both(G, g, mus, warm, settings):
    """(sweeps, converged, λ, σ) of the kernel and of the former one from the same warm start."""
    n = g.size
    out = []
    for f in (pgs_solve, _former_pgs):
        lam, sigma = warm.copy(), np.full(n, np.nan)
        sweeps, converged = f(G, g, mus, lam, *settings, np.empty((n, n)), np.empty(n), sigma)
        out.append((sweeps, converged, lam, sigma))
    return out


def _same(a, b) -> bool:
    return a[0] == b[0] and a[1] == b[1] and a[2].tobytes() == b[2].tobytes() and a[3].tobytes() == b[3].tobytes()


def test_the_sweep_equals_the_former_one_on_random_problems():
    """600 random problems (1-8 points, G = J M⁻¹ Jᵀ positive definite, warm or cold starts), under
    the simulator's settings and under looser and tighter tolerances and fewer sweeps (so that
    both stopping tests and the sweep limit end solves): equal bit for bit."""
    rng = np.random.default_rng(2626)
    settings = [(0.6, PGS_MAX_ITERATIONS, PGS_ABSOLUTE_PRECISION, PGS_RELATIVE_PRECISION),
                (0.6, 40, 1e-6, 1e-9), (1.0, 300, 1e-3, 0.0), (0.3, 7, 0.0, 1e-12)]
    stops = set()
    for k in range(600):
        nc = int(rng.integers(1, 9))
        nv = 3 * nc + int(rng.integers(0, 12))
        J = rng.normal(size=(3 * nc, nv))
        A = rng.normal(size=(nv, nv))
        G = J @ np.linalg.inv(A @ A.T + 0.1 * np.eye(nv)) @ J.T
        g = rng.normal(size=3 * nc)
        mus = rng.uniform(0.1, 1.2, nc)
        warm = np.zeros(3 * nc) if rng.random() < 0.5 else np.abs(rng.normal(size=3 * nc))
        s = settings[k % len(settings)]
        a, b = _both(G, g, mus, warm, s)
        assert _same(a, b), (k, a[:2], b[:2])
        stops.add((a[1], a[0] == s[1]))
    assert {(True, False), (False, True)} <= stops      # solves that converged and solves cut at the limit


def test_the_sweep_equals_the_former_one_on_a_standing_talos():
    """A Talos standing on its 8 sole corners, pushed about by random torques over 150 steps: every
    step's contact problem (G, g from the simulator's own rows, its warm start) solved the same."""
    robot = wbc.load_robot("talos")
    sim = Simulator.for_robot(robot, [ground(mu=0.8)])
    rng = np.random.default_rng(7)
    settings = (sim.over_relax, PGS_MAX_ITERATIONS, PGS_ABSOLUTE_PRECISION, PGS_RELATIVE_PRECISION)
    solved = 0
    for _ in range(150):
        m, d = sim.model, sim.data
        pin.computeJointJacobians(m, d, sim.q)
        J, _, depths, mus, ids = sim._contact_rows()
        if ids.size:
            Minv = pin.computeMinverse(m, m.createData(), sim.q)
            cr.symmetrise_upper(Minv)
            G = cr.delassus(J, Minv)
            g = cr.contact_velocity(J, sim.v, depths, sim.baumgarte, sim.h)
            a, b = _both(G, g, np.asarray(mus, float), sim._warm[ids].reshape(-1).copy(), settings)
            assert _same(a, b)
            solved += 1
        sim.step(rng.normal(scale=20.0, size=robot.model.nv))
    assert solved > 100


def test_the_disc_projection_near_the_edge_equals_the_former_one():
    """One contact from rest (G diagonal, so the first trial λ_t = −ω g_t / G_tt and λ_n = −ω g_n / G_nn),
    μ set so that ‖λ_t‖ is within 1e-16 to 1e-6 (relative) of μ λ_n, inside and outside the disc: the
    sweep's squared-norm pre-test projects exactly when the former √ does, bit for bit, on the first sweep
    and on the whole solve."""
    rng = np.random.default_rng(29)
    projected = inside = 0
    for _ in range(3000):
        d = rng.uniform(0.5, 2.0, 3)
        G = np.diag([d[0], d[0], d[2]])
        g = np.array([rng.normal(), rng.normal(), -rng.uniform(0.1, 2.0)])
        t = -(0.6 / d[0]) * g[:2]
        fz = -(0.6 / d[2]) * g[2]
        rel = 10.0 ** rng.uniform(-16, -6) * rng.choice([-1.0, 1.0])
        mus = np.array([np.sqrt(t @ t) / fz * (1.0 + rel)])
        for sweeps in (1, PGS_MAX_ITERATIONS):
            a, b = _both(G, g, mus, np.zeros(3), (0.6, sweeps, PGS_ABSOLUTE_PRECISION, PGS_RELATIVE_PRECISION))
            assert _same(a, b), (mus, rel, a[2], b[2])
            if sweeps == 1:
                scaled = np.sqrt(b[2][:2] @ b[2][:2]) < np.sqrt(t @ t)
                projected += scaled
                inside += not scaled
    assert projected > 500 and inside > 500
