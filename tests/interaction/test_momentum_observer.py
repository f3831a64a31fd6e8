"""The generalised-momentum observer (wbc.interaction.momentum_observer) against simulated external forces.

Fixed base: the Panda holding a posture under PD + gravity (5.5) in
:mod:`wbc.sim.compliant` (ABA with a known external wrench on the hand, 1 kHz).
Floating base: Talos in :class:`wbc.sim.Simulator` (a) in free fall, joints held by a
PD, pushed on the torso: nothing but the push is external, gravity is in the model;
(b) standing on the ground (rigid Coulomb contacts), pushed on the torso, with the
feet wrenches read by the simulator's 6-axis sensors (``contact_wrench``) and given
to the observer as known: then the residual is the push alone.

The true τ_ext over the interval [t_k, t_k+1) is J(q_k)ᵀ w (the simulators apply the
wrench at the interval's starting state); "ideal" below is that sequence passed
through the designed filter r⁺ = e^{−K_O h} r + (1 − e^{−K_O h}) τ_ext: what the
observer would output with exact dynamics terms.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.chapter import PDGravity
from wbc.interaction.momentum_observer import MomentumObserver, ObserverError
from wbc.sim import Simulator, ground
from wbc.sim.compliant import ExternalWrench, InteractionSim

DT = 1e-3
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def _ideal(tau_ext, gain, dt=DT):
    a = np.exp(-gain * dt)
    out, r = [], np.zeros(tau_ext.shape[1])
    for te in tau_ext:
        r = a * r + (1 - a) * te
        out.append(r)
    return np.array(out)


def _panda_push(panda, gain, t_push=0.2):
    """(T, r, τ_ext, ĥ, w): T the sample times after each step, τ_ext over the interval ending there."""
    w = np.array([12.0, -8.0, 10.0, 0.6, -0.4, 0.3])          # N, N·m about the hand origin, world axes
    q0 = panda.q_default.copy()
    push = ExternalWrench("hand", w, start=t_push - DT / 2)   # on from the step that starts at t_push
    sim = InteractionSim(panda, q0, dt=DT, wrenches=[push])
    ctrl = PDGravity(panda, q0, kp=[300.0] * 4 + [30.0] * 3, kd=[30.0] * 4 + [3.0] * 3)
    obs = MomentumObserver(panda, gain)
    obs.reset(sim.q, sim.v, sim.t)
    fid, d = panda.frame_id("hand"), panda.model.createData()
    T, R, TE, H = [], [], [], []
    for _ in range(round((t_push + 12 / gain) / DT)):
        tau = ctrl(sim.q, sim.v, sim.t)
        J = pin.computeFrameJacobian(panda.model, d, sim.q, fid, LWA)
        TE.append(J.T @ w if push.active(sim.t) else np.zeros(panda.nv))
        sim.step(tau)
        R.append(obs.update(sim.q, sim.v, tau, sim.t).copy())
        T.append(sim.t)
        H.append(obs.wrench("hand"))
    return np.array(T), np.array(R), np.array(TE), np.array(H), w


@pytest.mark.parametrize("gain", [20.0, 50.0])
def test_fixed_base_push_is_estimated_with_the_designed_time_constant(panda, gain):
    t_push = 0.2
    T, R, TE, H, w = _panda_push(panda, gain, t_push)
    scale = np.abs(TE).max()
    assert np.abs(R[T < t_push]).max() < 1e-9 * scale             # nothing external before the push
    # the residual is the designed first-order filter of the true τ_ext
    follow = np.abs(R - _ideal(TE, gain)).max() / scale
    # step response along τ_ext: 1 − e^{−n} at t = n / K_O, and the 63 % crossing time
    frac = np.einsum("ij,ij->i", R, TE) / np.maximum(np.einsum("ij,ij->i", TE, TE), 1e-300)
    fr = {n: frac[np.argmin(np.abs(T - (t_push + n / gain)))] for n in (1, 2, 3)}
    k = np.flatnonzero((T > t_push) & (frac >= 1 - np.exp(-1)))[0]
    t63 = T[k - 1] + (1 - np.exp(-1) - frac[k - 1]) / (frac[k] - frac[k - 1]) * DT - t_push
    # converged: 8 time constants after the push
    late = T >= t_push + 8 / gain
    err_tau = (np.linalg.norm(R[late] - TE[late], axis=1) / np.linalg.norm(TE[late], axis=1)).max()
    err_w = (np.linalg.norm(H[late] - w, axis=1) / np.linalg.norm(w)).max()
    print(f"Panda, K_O = {gain:g}/s: step response {fr[1]:.2%} / {fr[2]:.2%} / {fr[3]:.2%} at 1, 2, 3 × 1/K_O "
          f"(ideal 63.21 / 86.47 / 95.02 %), 63 % reached at {t63 * 1e3:.2f} ms (1/K_O = {1e3 / gain:.1f} ms); "
          f"|r − ideal filter| {follow:.2e} of max|τ_ext|; converged: τ_ext within {err_tau:.2%}, "
          f"wrench within {err_w:.2%}")
    assert follow < 5e-3
    # ±0.3 percentage points (a time constant within 0.8 %): the explicit-Euler sampling of (3)
    # would read 64.15 % at K_O h = 0.05; the arm's motion under the push changes τ_ext by < 0.05 %
    assert abs(fr[1] - (1 - np.exp(-1))) < 3e-3
    for n in (2, 3):
        assert abs(fr[n] - (1 - np.exp(-n))) < 5e-3
    assert abs(t63 * gain - 1.0) < 0.01
    assert err_tau < 0.05 and err_w < 0.05


def test_momentum_rate_identity_holds_on_a_floating_base(talos, rng):
    """Ṁ = C + Cᵀ (what (2) rests on), by central differences along q ⊕ v t, free flyer included."""
    m, d = talos.model, talos.model.createData()
    q, v = talos.q_default.copy(), rng.standard_normal(talos.nv)

    def M(x):
        A = pin.crba(m, d, x)
        return np.triu(A) + np.triu(A, 1).T

    h = 1e-6
    Mdot = (M(pin.integrate(m, q, h * v)) - M(pin.integrate(m, q, -h * v))) / (2 * h)
    C = pin.computeCoriolisMatrix(m, d, q, v)
    assert np.abs(Mdot - C - C.T).max() < 1e-6 * np.abs(Mdot).max()


def _talos_gains(talos, omega):
    """A critically damped joint PD of bandwidth ω (rad/s) on diag M(q_default). In the air a
    joint's effective inertia, 1 / (M⁻¹)_ii, is below M_ii: ω = 20 there, 40 standing."""
    d = talos.model.createData()
    b = np.diag(pin.crba(talos.model, d, talos.q_default))[talos.actuated_mask]
    return b * omega ** 2, 2 * b * omega


def _free_fall(talos, dt, f, t_push, gain):
    m, ja = talos.model, talos.actuated_mask
    q0 = talos.q_default.copy()
    w = np.concatenate([f, np.zeros(3)])
    sim = Simulator(m, [], [], q0, dt=dt, actuated=ja)
    sim.push("torso_2_link", f, t_push - dt / 2, 10.0)
    push = sim.pushes[0]
    obs = MomentumObserver(talos, gain)
    obs.reset(sim.q, sim.v, sim.t)
    kp, kd = _talos_gains(talos, 20.0)
    fid, d = talos.frame_id("torso_2_link"), m.createData()
    T, R, TE, H = [], [], [], []
    for _ in range(round(0.6 / dt)):
        tau = kp * pin.difference(m, sim.q, q0)[ja] - kd * sim.v[ja]
        J = pin.computeFrameJacobian(m, d, sim.q, fid, LWA)
        TE.append(J.T @ w if push.active(sim.t) else np.zeros(m.nv))
        sim.step(tau)
        R.append(obs.update(sim.q, sim.v, tau, sim.t).copy())
        T.append(sim.t), H.append(obs.wrench(fid))
    return sim, w, *map(np.array, (T, R, TE, H))


def test_floating_base_push_in_free_fall(talos):
    """Free fall (no ground): gravity is in the model, so the residual is the torso push alone,
    on the root rows as well as the joints; r follows the designed filter of J_torsoᵀ w up to
    the O(h) of the discrete dynamics terms (it halves with h)."""
    f, t_push, gain = np.array([40.0, -25.0, 15.0]), 0.1, 50.0
    follow = []
    for dt in (DT, DT / 2):
        sim, w, T, R, TE, H = _free_fall(talos, dt, f, t_push, gain)
        scale = np.abs(TE).max()
        follow.append(np.abs(R - _ideal(TE, gain, dt)).max() / scale)
        if dt == DT:
            assert np.abs(R[T < t_push]).max() < 1e-9 * scale
            late = T >= t_push + 8 / gain
            err_tau = (np.linalg.norm(R[late] - TE[late], axis=1) / np.linalg.norm(TE[late], axis=1)).max()
            err_w = (np.linalg.norm(H[late] - w, axis=1) / np.linalg.norm(w)).max()
            fall, spin, h_last = -sim.v[2], np.linalg.norm(sim.v[3:6]), H[-1]
    print(f"Talos in free fall (falling at {fall:.1f} m/s, turning at {spin:.2f} rad/s), torso push {f} N: "
          f"|r − ideal filter| {follow[0]:.2e} at 1 kHz, {follow[1]:.2e} at 2 kHz; converged: τ_ext within "
          f"{err_tau:.2%}, wrench within {err_w:.2%} (the filter's lag behind a τ_ext that turns with the "
          f"root), ĥ = {np.round(h_last, 2)}")
    assert follow[0] < 1e-2 and 1.7 < follow[0] / follow[1] < 2.3
    assert err_tau < 0.05 and err_w < 0.05


def test_standing_humanoid_push_with_the_feet_wrenches_known(talos):
    """On the ground the observer sees the contact forces as external too (r ≈ J_torsoᵀ w +
    Σ J_footᵀ w_foot); with the feet sensors' wrenches given as known, r is the push."""
    m, ja = talos.model, talos.actuated_mask
    q0 = talos.q_default.copy()
    sim = Simulator.for_robot(talos, [ground()], q0)
    f, t_push, gain = np.array([15.0, -10.0, 5.0]), 0.4, 50.0
    w = np.concatenate([f, np.zeros(3)])
    sim.push("torso_2_link", f, t_push - DT / 2, 10.0)
    push = sim.pushes[0]
    feet = [c.frame for c in talos.contacts.values()]
    fids = [talos.frame_id(x) for x in feet]
    known, total = MomentumObserver(talos, gain), MomentumObserver(talos, gain)
    known.reset(sim.q, sim.v, sim.t), total.reset(sim.q, sim.v, sim.t)
    kp, kd = _talos_gains(talos, 40.0)
    tid, d = talos.frame_id("torso_2_link"), m.createData()
    T, RK, RT, PUSH, ALL, H = [], [], [], [], [], []
    for k in range(round(1.0 / DT)):
        if k == round(t_push / DT):
            z_push = sim.q[2]
        g = pin.computeGeneralizedGravity(m, d, sim.q)
        tau = g[ja] + kp * pin.difference(m, sim.q, q0)[ja] - kd * sim.v[ja]
        q_k = sim.q.copy()
        tp = pin.computeFrameJacobian(m, d, q_k, tid, LWA).T @ w if push.active(sim.t) else np.zeros(m.nv)
        sim.step(tau)
        # what the foot sensors read over the step (wrench in the sole frame, about its origin)
        tau_feet = sum(pin.computeFrameJacobian(m, d, q_k, fid, pin.ReferenceFrame.LOCAL).T @ sim.contact_wrench(fr)
                       for fr, fid in zip(feet, fids))
        RK.append(known.update(sim.q, sim.v, tau, sim.t, tau_known=tau_feet).copy())
        RT.append(total.update(sim.q, sim.v, tau, sim.t).copy())
        T.append(sim.t), PUSH.append(tp), ALL.append(tp + tau_feet), H.append(known.wrench(tid))
    T, RK, RT, PUSH, ALL, H = map(np.array, (T, RK, RT, PUSH, ALL, H))
    assert abs(sim.q[2] - z_push) < 5e-3                           # still standing (root within 5 mm)
    late = T >= t_push + 8 / gain
    err_push = (np.linalg.norm(RK[late] - PUSH[late], axis=1) / np.linalg.norm(PUSH[late], axis=1)).max()
    err_w = (np.linalg.norm(H[late] - w, axis=1) / np.linalg.norm(w)).max()
    err_all = (np.linalg.norm((RT - _ideal(ALL, gain))[late], axis=1) / np.linalg.norm(ALL[late], axis=1)).max()
    print(f"Talos standing, torso push {f} N, feet wrenches known: push τ_ext within {err_push:.2%}, "
          f"wrench within {err_w:.2%}, ĥ = {np.round(H[-1], 2)}; feet unknown: r is the filtered "
          f"push + contacts within {err_all:.2%} (root force {np.round(RT[-1][:3], 1)} N)")
    assert err_push < 0.05 and err_w < 0.05
    assert err_all < 0.01
    assert np.linalg.norm(RT[-1][:3]) > 0.9 * talos.mass * 9.81     # the ground carries the weight


def test_misuse_is_named(panda):
    with pytest.raises(ObserverError, match="gain K_O must be finite and > 0"):
        MomentumObserver(panda, 0.0)
    with pytest.raises(ObserverError, match="gain must be a number or 7"):
        MomentumObserver(panda, [1.0, 2.0])
    obs = MomentumObserver(panda, 10.0)
    with pytest.raises(ObserverError, match="call reset"):
        obs.update(panda.q_default, np.zeros(7), np.zeros(7), 0.001)
    obs.reset(panda.q_default, np.zeros(7), 0.0)
    with pytest.raises(ObserverError, match="time must increase"):
        obs.update(panda.q_default, np.zeros(7), np.zeros(7), 0.0)
