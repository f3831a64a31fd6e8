"""The compiled PGS (wbc.sim.pgs) against pinocchio's binding, and the Coulomb conditions it meets;
the simulator's one-call contact step against the same step done piece by piece."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.sim import contact_rows as cr
from wbc.sim.contact_solver import ContactSolver
from wbc.sim.environment import ground
from wbc.sim.pgs import CompiledPGS
from wbc.sim.simulator import Simulator

PIN4 = not hasattr(pin, "PGSContactSolver")


def _problem(rng, nc: int, extra: int):
    """A random frictional contact problem of nc points: G = J M⁻¹ Jᵀ with J (3nc × nv), nv =
    3nc + extra (G positive definite), M symmetric positive definite; g, μ and a warm start."""
    nv = 3 * nc + extra
    J = rng.normal(size=(3 * nc, nv))
    A = rng.normal(size=(nv, nv))
    Minv = np.linalg.inv(A @ A.T + 0.1 * np.eye(nv))
    G = J @ Minv @ J.T
    g = rng.normal(size=3 * nc)
    mus = tuple(rng.uniform(0.1, 1.2, nc))
    warm = np.zeros(3 * nc) if rng.random() < 0.5 else np.abs(rng.normal(size=3 * nc))
    return G, g, mus, warm


@pytest.mark.skipif(not PIN4, reason="pinocchio 3's PGSContactSolver is another rule (see the docstring)")
def test_compiled_pgs_equals_pinocchio_on_random_contact_problems():
    """400 random problems (1-8 points, G positive definite), the simulator's settings. On
    pinocchio 4 the compiled PGS is the binding's rule: the same converged flag, the same
    sweeps (±1) and λ equal to 1e-9 of ‖λ‖ (measured: bit for bit; the tolerance leaves room
    for another Eigen build's product order, which moves λ by rounding, ~1e-15 relative,
    unless a stopping test then flips by one sweep, which moves λ by at most the relative
    precision 1e-12 of ‖λ‖). Pinocchio 3's binding is not compared: its residuals see only the
    tangential update (module docstring of wbc.sim.pgs), so a sweep that moves no tangential
    impulse (one that sets every λ to 0 from a warm start) passes its absolute test at a point
    that is no fixed point, and the Coulomb problem's fixed point need not be unique either;
    there the Coulomb conditions below and the simulator comparison at the end hold."""
    rng = np.random.default_rng(26)
    for _ in range(400):
        G, g, mus, warm = _problem(rng, int(rng.integers(1, 9)), int(rng.integers(0, 12)))
        ref, ours = ContactSolver(mus), CompiledPGS(mus)
        la, lb = ref.solve(G, g, warm), ours.solve(G, g, warm)
        assert ours.converged == ref.converged
        assert abs(ours.sweeps - (ref._result.iterations + ref.converged)) <= 1
        assert np.abs(la - lb).max() <= 1e-9 * max(1.0, np.abs(la).max())


@pytest.mark.parametrize("seed", range(5))
def test_compiled_pgs_meets_the_coulomb_conditions(seed):
    """Its fixed point: each λ_i in its cone; the contact velocity σ = Gλ + g never
    penetrates (σ_n ≥ −tol); a pushing contact does not separate (λ_n > 0 ⇒ σ_n ≈ 0); a
    sticking one does not slide (‖λ_t‖ < μλ_n ⇒ σ_t ≈ 0); a sliding one pushes against its
    slip (λ_t = −μλ_n σ_t/‖σ_t‖). Run to a relative step of 1e-13 with the absolute test off
    (absolute_precision < 0): that test, pinocchio's, reads each contact's σ when that contact
    was updated, before the later ones moved, and can stop early with an earlier contact
    penetrating (seen here on warm-started problems after one sweep; the binding does the same).
    Tolerance 1e-6 of the problem's scale, far outside a 1e-13 step's effect."""
    rng = np.random.default_rng(100 + seed)
    checked = 0
    for _ in range(40):
        G, g, mus, warm = _problem(rng, int(rng.integers(1, 6)), 6)
        s = CompiledPGS(mus, max_iterations=20000, absolute_precision=-1.0, relative_precision=1e-13)
        lam = s.solve(G, g, warm)
        if not s.converged:
            continue
        checked += 1
        sig = G @ lam + g
        tol = 1e-6 * (1.0 + np.abs(g).max())
        for i, mu in enumerate(mus):
            lt, ln = lam[3 * i: 3 * i + 2], lam[3 * i + 2]
            st, sn = sig[3 * i: 3 * i + 2], sig[3 * i + 2]
            assert ln >= 0.0 and np.linalg.norm(lt) <= mu * ln * (1 + 1e-12) + 1e-300
            assert sn >= -tol
            if ln > 1e-6:
                assert abs(sn) <= tol
                if np.linalg.norm(lt) < mu * ln * (1 - 1e-6):
                    assert np.linalg.norm(st) <= tol
                elif np.linalg.norm(st) > tol:
                    np.testing.assert_allclose(lt, -mu * ln * st / np.linalg.norm(st), atol=1e-5 * (1 + ln))
    assert checked >= 20


def test_compiled_pgs_layout_and_warm_start():
    """One point of mass m falling at (1, −0.5, −2) m/s (G = I/m): λ_n = 2m stops it, the
    tangential impulse is −m v_t within the cone (μ = 1.5), its boundary otherwise (μ = 0.3);
    the warm start is not modified."""
    m, v = 3.0, np.array([1.0, -0.5, -2.0])
    for mu in (0.3, 1.5):
        warm = np.array([0.1, 0.2, 0.3])
        keep = warm.copy()
        lam = CompiledPGS((mu,)).solve(np.eye(3) / m, v, warm)
        assert np.array_equal(warm, keep)
        lam_n = -m * v[2]
        vt = v[:2]
        lam_t = -m * vt if m * np.linalg.norm(vt) <= mu * lam_n else -mu * lam_n * vt / np.linalg.norm(vt)
        np.testing.assert_allclose(lam, np.r_[lam_t, lam_n], rtol=1e-9, atol=1e-9)


def test_one_call_contact_step_equals_the_step_piece_by_piece():
    """Talos standing, 1 mm low and tilted: the simulator's one compiled call (rows → G, g →
    PGS → v⁺, forces, warm start) gives what the pieces give with the same compiled PGS, bit
    for bit (the same kernels on the same arrays), keeps no warm start for a point out of
    contact, and its rows equal pinocchio's
    LOCAL_WORLD_ALIGNED joint Jacobians shifted to each point (1e-12)."""
    robot = wbc.load_robot("talos")
    sim = Simulator.for_robot(robot, [ground()])
    rng = np.random.default_rng(3)
    m, d = sim.model, sim.data
    for _ in range(5):
        q = robot.q_default.copy()
        q[2] -= 0.001
        q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(*(0.01 * rng.standard_normal(3)))).coeffs()
        v = 0.05 * rng.standard_normal(m.nv)
        sim.q = q                   # the simulator's contract: its data's kinematics are at its q
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        J, frames, depths, mus, ids = (a.copy() for a in sim._contact_rows())
        assert ids.size >= 4
        for k, i in enumerate(ids):
            jid, r = sim.points[i]
            Jj = pin.getJointJacobian(m, d, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            p = d.oMi[jid].act(r)
            Jp = Jj[:3] - pin.skew(p - d.oMi[jid].translation) @ Jj[3:]
            np.testing.assert_allclose(J[3 * k: 3 * k + 3], frames[k].T @ Jp, atol=1e-12)
        Minv = pin.computeMinverse(m, d, q)
        cr.symmetrise_upper(Minv)
        v_free = v + 1e-3 * rng.standard_normal(m.nv)
        warm = np.abs(rng.standard_normal((len(sim.points), 3)))   # points out of contact too: dropped
        forces = np.zeros((len(sim.points), 3))
        warm_fused = warm.copy()
        v_fused, sweeps, _, finite = cr.contact_step((J, depths, mus, frames, ids), Minv, v_free,
                                                     (0.2, 1e-3, 0.6, 300, 1e-10, 1e-12), (warm_fused, forces))
        assert finite and sweeps >= 1
        G = J @ Minv @ J.T
        g = J @ v_free
        g[2::3] -= np.where(depths > 0, 0.2 * depths, depths) / 1e-3
        lam = CompiledPGS(tuple(mus)).solve(cr.delassus(J, Minv), cr.contact_velocity(J, v_free, depths, 0.2, 1e-3),
                                            warm[ids].ravel())
        np.testing.assert_allclose(cr.delassus(J, Minv), G, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(cr.contact_velocity(J, v_free, depths, 0.2, 1e-3), g, rtol=1e-12, atol=1e-12)
        assert np.array_equal(warm_fused[ids].ravel(), lam)
        assert not warm_fused[np.setdiff1d(np.arange(len(sim.points)), ids)].any()
        assert np.array_equal(v_fused, v_free + Minv @ (J.T @ lam))
        np.testing.assert_allclose(forces[ids], np.einsum("kab,kb->ka", frames, lam.reshape(-1, 3)) / 1e-3, rtol=1e-14)


def test_simulators_with_either_contact_solver_agree():
    """Talos standing under gravity torques for 0.2 s: the simulator with the compiled PGS and
    with pinocchio's binding. On pinocchio 4 (the same PGS rule) the trajectories agree to
    1e-9; on pinocchio 3 (other stopping tests) to 1e-6 (m, rad)."""
    robot = wbc.load_robot("talos")
    sims = [Simulator.for_robot(robot, [ground()], contact_solver=name) for name in ("compiled", "pinocchio")]
    tau = pin.computeGeneralizedGravity(robot.model, robot.model.createData(), robot.q_default)
    tau[: robot.n_root] = 0.0
    for _ in range(200):
        for s in sims:
            s.step(tau)
    assert np.abs(sims[0].q - sims[1].q).max() <= (1e-9 if PIN4 else 1e-6)
    with pytest.raises(wbc.WbcError, match="contact_solver"):
        Simulator.for_robot(robot, [ground()], contact_solver="lcp")
