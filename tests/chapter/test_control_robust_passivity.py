"""Robust Slotine-Li (chapter 5.2.1) on the Panda with an uncertain payload.

The simulated plant is the Panda carrying a 2 kg payload on its last link (CoM 3 cm
off the flange axis, 20 cm out; ``with_payload``: added to the simulated model only);
the controller's model is the bare Panda with π₀ = its parameters plus 0.7 × the
payload's (a payload 30 % light). Uncertain set S: the last body's 10 parameters,
normed in lengths of L = 0.2 m (the payload's reach; ``body_parameter_scale``), with
ρ = 1.25 ‖S⁻¹ (π − π₀)‖. Plant: :class:`wbc.sim.Simulator` (ABA, semi-implicit Euler,
1 kHz, zero-order hold), as in the joint-space tests.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.chapter import (
    PassivityBased,
    RobustPassivityBased,
    body_parameter_indices,
    body_parameter_scale,
    dynamic_parameters,
    slotine_li_regressor,
    with_payload,
)
from wbc.sim import Simulator
from wbc.trajectories.position import Sinusoid

DT = 1e-3
KD = np.array([10.0] * 4 + [2.0] * 3)
LAM = 5.0
PAYLOAD = pin.Inertia(2.0, np.array([0.03, 0.0, 0.2]), np.diag([3e-3, 3e-3, 2e-3]))


@pytest.fixture(scope="module")
def setup():
    robot = wbc.load_robot("panda")
    S = body_parameter_indices(robot.model)
    pay = PAYLOAD.toDynamicParameters()
    pi0 = dynamic_parameters(robot.model)
    pi0[S] += 0.7 * pay
    scale = body_parameter_scale(0.2)
    rho = 1.25 * float(np.linalg.norm(0.3 * pay / scale))
    q0 = robot.q_default.copy()
    s = Sinusoid(amplitude=np.array([0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5]), frequency=0.4, ramp=0.0)

    def ref(t):
        x, dx, ddx = s.sample(t)
        return q0 + x, dx, ddx

    return dict(robot=robot, plant=with_payload(robot.model, PAYLOAD), pi0=pi0, scale=scale, rho=rho,
                ref=ref, q0=q0)


def _run(setup, ctrl, duration, power=None):
    """Closed loop from q_d(0) + 0.1 rad; (T, ‖e‖, ‖σ‖, τ) per step and the plant's B eigenvalue range.
    ``power``: a list that receives wᵀ(Δ − δπ_S) per step (W), Δ the true parameter error."""
    ref, plant = setup["ref"], setup["plant"]
    sim = Simulator(plant, [], [], setup["q0"] + 0.1, dt=DT)
    d = plant.createData()
    T, E, SIG, TAU, b = [], [], [], [], [np.inf, 0.0]
    for k in range(round(duration / DT)):
        t = k * DT
        tau = ctrl(sim.q, sim.v, t)
        if power is not None:
            power.append(ctrl.last_w @ (0.3 * PAYLOAD.toDynamicParameters() - ctrl.last_delta))
        qd, vd, _ = ref(t)
        e = qd - sim.q
        T.append(t), E.append(np.linalg.norm(e)), SIG.append(np.linalg.norm(vd - sim.v + LAM * e)), TAU.append(tau)
        if k % 50 == 0:
            M = pin.crba(plant, d, sim.q)
            ev = np.linalg.eigvalsh(np.triu(M) + np.triu(M, 1).T)
            b = [min(b[0], ev[0]), max(b[1], ev[-1])]
        sim.step(tau)
    return np.array(T), np.array(E), np.array(SIG), np.array(TAU), b


def _margin(ctrl, ref, duration):
    return max(ctrl.sampling_margin(ref(t)[0], ref(t)[1], t, DT) for t in np.linspace(0.0, duration, 21))


def test_regressor_columns_of_the_last_body_carry_the_payload(setup, rng):
    """Y_S (π_true,S − π₀,S) is the torque the wrong payload estimate leaves out:
    RNEA of the plant minus RNEA of the estimated model, at any (q, q̇, q̇_r, q̈_r)."""
    robot, plant = setup["robot"], setup["plant"]
    S = body_parameter_indices(robot.model)
    est = with_payload(robot.model, pin.Inertia.FromDynamicParameters(0.7 * PAYLOAD.toDynamicParameters()))
    dp, de = plant.createData(), est.createData()
    for _ in range(3):
        q = robot.random_configuration(rng)
        v, a = rng.standard_normal((2, 7))
        Y = slotine_li_regressor(robot.model, robot.model.createData(), q, v, v, a)
        gap = pin.rnea(plant, dp, q, v, a) - pin.rnea(est, de, q, v, a)
        assert np.abs(Y[:, S] @ (0.3 * PAYLOAD.toDynamicParameters()) - gap).max() < 1e-9 * np.abs(gap).max()
        assert np.abs(np.delete(Y, S, axis=1) @ np.delete(dynamic_parameters(robot.model), S)
                      + Y[:, S] @ setup["pi0"][S] - pin.rnea(est, de, q, v, a)).max() < 1e-9


def test_ultimate_bound_shrinks_with_the_boundary_layer_and_stays_stable_at_1khz(setup):
    robot, ref = setup["robot"], setup["ref"]
    duration, late_from = 4.0, 1.5           # the window [1.5, 4] s is one period of the motion
    nominal = PassivityBased(robot, ref, kd=KD, lam=LAM, params=setup["pi0"])
    T, E, _, TAU, _ = _run(setup, nominal, duration)
    late = T >= late_from
    e_nominal, chatter_nominal = E[late].max(), np.abs(np.diff(TAU[late], axis=0)).max()
    bound, sig, margin, chatter, bar = {}, {}, {}, {}, {}
    for eps in (3.0, 1.0, 0.3):
        ctrl = RobustPassivityBased(robot, ref, kd=KD, lam=LAM, rho=setup["rho"], eps=eps,
                                    params=setup["pi0"], scale=setup["scale"])
        power = []
        T, E, SIG, TAU, (b_min, b_max) = _run(setup, ctrl, duration, power)
        # the step of the proof: the uncertainty's power wᵀ(Δ − δπ) never exceeds ρε/4 ...
        assert max(power) <= setup["rho"] * eps / 4 * (1 + 1e-12), (eps, max(power))
        bound[eps], sig[eps] = E[late].max(), SIG[late].max()
        chatter[eps] = np.abs(np.diff(TAU[late], axis=0)).max()
        margin[eps] = _margin(ctrl, ref, duration)
        bar[eps], _ = ctrl.ultimate_bound(b_min, b_max)
        # the Lyapunov bound (3) holds (it is conservative: √(κ(B)) ≈ 20 on the Panda)
        assert sig[eps] < bar[eps], (eps, sig[eps], bar[eps])
    print(f"robust Slotine-Li, 30 % light 2 kg payload, ρ = {setup['rho']:.2f}: ultimate max ‖e‖ "
          f"nominal π₀ {e_nominal * 1e3:.1f} mrad; "
          + ", ".join(f"ε = {k:g}: {v * 1e3:.1f} mrad (‖σ‖ {sig[k]:.3f} rad/s ≤ σ̄ {bar[k]:.2f}, "
                      f"sampling margin {margin[k]:.2f}, max |Δτ| per step {chatter[k]:.3f} N·m)"
                      for k, v in bound.items())
          + f"; nominal max |Δτ| {chatter_nominal:.3f} N·m")
    assert e_nominal > 2.0 * bound[3.0]                           # the robust term does the work
    assert bound[3.0] > 1.4 * bound[1.0] > 1.4 * 1.4 * bound[0.3]  # and shrinks with ε
    for eps in bound:
        assert margin[eps] < 1.0                                   # the sampled loop is stable ...
        assert chatter[eps] < 3.0 * chatter_nominal                # ... and does not chatter


def test_a_norm_bound_over_all_70_parameters_does_not_sample_at_1khz(setup):
    """Same ε = 0.3, ρ = 30 % of ‖π₀‖ over every body (each normed in the same L): the
    boundary-layer gain (ρ/ε) Y Yᵀ exceeds the 1 kHz sampling limit and the torque
    chatters; the payload-only law (previous test) is stable at that ε. Normed in metres
    (S = I) even the payload-only law is past the limit at that ε."""
    robot, ref = setup["robot"], setup["ref"]
    scale = np.tile(body_parameter_scale(0.2), 7)
    ctrl = RobustPassivityBased(robot, ref, kd=KD, lam=LAM, rho=0.3 * float(np.linalg.norm(setup["pi0"] / scale)),
                                eps=0.3, params=setup["pi0"], uncertain="all", scale=scale)
    margin_all = _margin(ctrl, ref, 1.0)
    T, E, _, TAU, _ = _run(setup, ctrl, 1.0)
    chatter = np.abs(np.diff(TAU[T >= 0.5], axis=0)).max()
    metres = RobustPassivityBased(robot, ref, kd=KD, lam=LAM, rho=1.25 * 0.3 * float(np.linalg.norm(
        PAYLOAD.toDynamicParameters())), eps=0.3, params=setup["pi0"])
    margin_metres = _margin(metres, ref, 1.0)
    print(f"ε = 0.3: 70-parameter bound, sampling margin {margin_all:.1f}, max |Δτ| per step {chatter:.1f} N·m; "
          f"payload in metres (S = I) margin {margin_metres:.1f}")
    assert margin_all > 2.0 and margin_metres > 2.0
    assert chatter > 10.0
