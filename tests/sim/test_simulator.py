"""Physics checks of the contact simulator (wbc.sim) on a passive free-flying box.

The simulator's discrete dynamics (semi-implicit Euler, rigid Coulomb contacts
solved by PGS, Baumgarte push-out) make these checks sharp: a box at rest has
no velocity to integrate, so "does not move" is tested at 1e-6 m, and Coulomb
sliding is reproduced to solver precision, so accelerations are tested against
the closed-form g (sin θ − μ cos θ) within 2 %.

Corner positions are computed here from ``sim.q`` with a private pinocchio
Data: ``Simulator.point_positions()`` returns the kinematics of the start of the
last step (one step behind ``sim.q``), which would blur penetration checks.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.errors import WbcError
from wbc.sim import Simulator, box_model, ground, incline

DT = 1e-3
CUBE = (0.2, 0.2, 0.2)
FLAT = (0.3, 0.2, 0.1)


# ---------------------------------------------------------------- helpers
def _gravity(model: pin.Model) -> float:
    return float(np.linalg.norm(model.gravity.linear))


def _corners(model: pin.Model, points, q: np.ndarray) -> np.ndarray:
    """World positions of the contact points at configuration q (fresh kinematics)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    return np.array([data.oMi[model.getJointId(j)].act(r) for j, r in points])


def _rotation(q: np.ndarray) -> np.ndarray:
    return pin.Quaternion(np.asarray(q[3:7])).normalized().matrix()


def _angle_between(qa: np.ndarray, qb: np.ndarray) -> float:
    return float(np.linalg.norm(pin.log3(_rotation(qa).T @ _rotation(qb))))


def _random_rotation(seed: int) -> np.ndarray:
    return pin.exp3(np.random.default_rng(seed).normal(size=3))


def _drop(size, mass, height, R=None, omega=None, mu=0.8):
    """A box whose lowest corner is ``height`` above the ground, at rest or spinning
    (``omega`` in the body frame, rad/s; default at rest, R default identity)."""
    R = np.eye(3) if R is None else R
    omega = np.zeros(3) if omega is None else omega
    m, pts = box_model(size=size, mass=mass)
    corners_body = np.array([r for _, r in pts])
    z = height - (corners_body @ R.T)[:, 2].min()
    q0 = np.r_[0.0, 0.0, z, pin.Quaternion(R).coeffs()]
    v0 = np.r_[np.zeros(3), omega]
    return Simulator(m, pts, [ground(mu=mu)], q0, v0=v0, dt=DT), m, pts


def _run(sim: Simulator, seconds: float, each=None) -> None:
    for _ in range(int(round(seconds / sim.dt))):
        sim.step(np.zeros(6))
        if each is not None:
            each(sim)


# ---------------------------------------------------------------- (a) drop and settle
@pytest.mark.parametrize(
    "size, mass, tilt_seed",
    [(CUBE, 5.0, None), (CUBE, 5.0, 7), (FLAT, 2.0, 3)],
    ids=["cube-flat", "cube-random-tilt", "slab-random-tilt"],
)
def test_dropped_box_settles_without_penetration_or_drift(size, mass, tilt_seed):
    R = np.eye(3) if tilt_seed is None else _random_rotation(tilt_seed)
    sim, m, pts = _drop(size, mass, 0.3, R)
    mg = mass * _gravity(m)

    worst = {"pen": 0.0}

    def track(s):
        worst["pen"] = max(worst["pen"], -_corners(m, pts, s.q)[:, 2].min())

    _run(sim, 2.5, track)          # fall (~0.25 s), impact, tumble onto a face
    # Rigid contact + Baumgarte: the only penetration is the one-step overshoot at
    # impact, which is then removed geometrically (×(1 − β) per step).
    assert worst["pen"] <= 1e-3, f"penetration during the drop {worst['pen']:.3g} m"
    assert np.abs(sim.v).max() < 1e-5, f"not at rest after 2.5 s: |v|max = {np.abs(sim.v).max():.3g}"

    c = _corners(m, pts, sim.q)
    touching = np.abs(c[:, 2]) < 1e-6
    assert touching.sum() == 4, f"box should rest on a face, corner heights {np.sort(c[:, 2])}"
    # At rest the Baumgarte residue has decayed as 0.8^n: only solver noise is left.
    assert -c[:, 2].min() <= 1e-6

    # Normal forces carry the weight exactly (the velocity is zero, so the impulse
    # is exactly m g h); tangential forces cancel.
    F = sim.point_forces.sum(axis=0)
    assert abs(F[2] / mg - 1.0) <= 1e-6, f"sum of normal forces {F[2]} N vs m g = {mg} N"
    assert np.linalg.norm(F[:2]) <= 1e-4 * mg

    q_rest = sim.q.copy()
    worst["pen"] = 0.0
    _run(sim, 10.0, track)
    drift = np.linalg.norm(sim.q[:3] - q_rest[:3])
    assert drift <= 1e-3, f"position drift over 10 s of rest: {drift:.3g} m"
    assert _angle_between(sim.q, q_rest) <= 1e-3, "orientation drift over 10 s of rest"
    assert worst["pen"] <= 1e-6, f"penetration during rest {worst['pen']:.3g} m"
    F = sim.point_forces.sum(axis=0)
    assert abs(F[2] / mg - 1.0) <= 1e-6, f"sum of normal forces {F[2]} N vs m g = {mg} N"


@pytest.mark.parametrize("yaw", [0.0, 0.3, 0.8])   # 0.8 rad rattled before PGS under-relaxation
@pytest.mark.parametrize(
    "size, mass", [pytest.param(CUBE, 5.0, id="cube"), pytest.param(FLAT, 2.0, id="slab")])
def test_box_placed_at_rest_stays_at_rest(size, mass, yaw):
    """Exactly resting flat on the ground: nothing may move (no velocity to integrate)."""
    m, pts = box_model(size=size, mass=mass)
    R = pin.exp3(np.array([0.0, 0.0, yaw]))
    q0 = np.r_[0.0, 0.0, 0.5 * size[2], pin.Quaternion(R).coeffs()]
    sim = Simulator(m, pts, [ground(mu=0.8)], q0, dt=DT)
    vmax = [0.0]
    _run(sim, 2.0, lambda s: vmax.__setitem__(0, max(vmax[0], np.abs(s.v).max())))
    assert vmax[0] < 1e-6, f"a resting box reached |v| = {vmax[0]:.3g}"
    assert np.linalg.norm(sim.q[:3] - q0[:3]) < 1e-6
    assert _angle_between(sim.q, q0) < 1e-6
    assert abs(sim.point_forces[:, 2].sum() / (mass * _gravity(m)) - 1.0) <= 1e-6


# ---------------------------------------------------------------- (b) incline
@pytest.mark.parametrize("mu", [0.3, 0.6])
@pytest.mark.parametrize("offset_deg", [-3.0, 3.0], ids=["below", "above"])
def test_box_on_incline_slides_iff_tan_theta_exceeds_mu(mu, offset_deg):
    theta = np.arctan(mu) + np.radians(offset_deg)
    size, mass = CUBE, 5.0   # cube: tipping would need μ > 1 (sx/sz), never reached here
    m, pts = box_model(size=size, mass=mass)
    plane = incline(theta, mu)
    n = plane.normal
    assert np.allclose(n, [-np.sin(theta), 0.0, np.cos(theta)])
    R = pin.exp3(np.array([0.0, -theta, 0.0]))          # body z along the plane normal
    q0 = np.r_[0.5 * size[2] * n, pin.Quaternion(R).coeffs()]

    # The box rests flat: four corners on the plane, four one box-height above it.
    heights = np.sort(_corners(m, pts, q0) @ n)
    assert np.allclose(heights[:4], 0.0, atol=1e-12)
    assert np.allclose(heights[4:], size[2], atol=1e-12)

    sim = Simulator(m, pts, [plane], q0, dt=DT)
    downhill = np.array([-np.cos(theta), 0.0, -np.sin(theta)])   # the plane rises along +x
    T = 1.0
    t, s, lift = [], [], []

    def record(sm):
        d = sm.q[:3] - q0[:3]
        t.append(sm.t)
        s.append(d @ downhill)
        lift.append(abs(d @ n))

    _run(sim, T, record)
    t, s = np.array(t), np.array(s)
    g = _gravity(m)

    if np.tan(theta) < mu:
        disp = np.linalg.norm(sim.q[:3] - q0[:3])
        assert disp < 1e-6, f"box crept {disp:.3g} m on a {np.degrees(theta):.1f}° slope with μ={mu}"
        assert _angle_between(sim.q, q0) < 1e-6
    else:
        a_expected = g * (np.sin(theta) - mu * np.cos(theta))
        a_measured = 2.0 * np.polyfit(t, s, 2)[0]
        assert s[-1] > 0.2, "box should slide downhill"
        assert abs(a_measured / a_expected - 1.0) <= 0.02, (
            f"slide acceleration {a_measured:.5f} vs g(sinθ − μcosθ) = {a_expected:.5f} m/s²")
        # sliding, not hopping or tumbling
        assert max(lift) < 1e-6
        assert _angle_between(sim.q, q0) < 1e-3


# ---------------------------------------------------------------- (c) energy
@pytest.mark.parametrize("height", [0.05, 0.3, 1.0])
@pytest.mark.parametrize(
    "size, mass, tilt_seed, spin",
    [(CUBE, 5.0, None, 0.0), (CUBE, 5.0, 11, 2.0), (FLAT, 2.0, 5, 2.0)],
    ids=["cube-upright", "cube-tilted-spinning", "slab-tilted-spinning"],
)
def test_dropped_box_never_gains_energy(height, size, mass, tilt_seed, spin):
    """E(t) ≤ E(0) (1 + 1e-6) throughout, and no rebound above the drop height.

    No Baumgarte allowance is needed: the push-out only acts after the impact,
    which has already dissipated far more than it can restore (≤ m g · depth,
    depth < 1 mm). The root's body-frame velocity is rotated exactly in free flight
    (see test_force_free_spinning_box_keeps_its_energy_and_speed), so spin adds none.
    """
    R = np.eye(3) if tilt_seed is None else _random_rotation(tilt_seed)
    omega = np.zeros(3)
    if spin:
        w = np.random.default_rng(tilt_seed + 1).normal(size=3)
        omega = spin * w / np.linalg.norm(w)
    sim, m, pts = _drop(size, mass, height, R, omega)
    E0, z0 = sim.energy(), sim.q[2]
    state = {"Emax": E0, "hit": None, "zmax_after": -np.inf}

    def watch(s):
        state["Emax"] = max(state["Emax"], s.energy())
        if state["hit"] is None and s.point_forces.any():
            state["hit"] = s.q[2]
        if state["hit"] is not None:
            state["zmax_after"] = max(state["zmax_after"], s.q[2])

    _run(sim, np.sqrt(2 * height / _gravity(m)) + 1.0, watch)

    assert state["hit"] is not None, "the box never touched the ground"
    assert state["Emax"] <= E0 * (1.0 + 1e-6), f"energy rose to {state['Emax'] / E0:.9f} × E(0)"
    assert state["zmax_after"] <= z0, "the centre rose above its drop height after the impact"
    if tilt_seed is None and not spin:
        # Flat, non-spinning impact is perfectly inelastic: no bounce at all.
        assert state["zmax_after"] - state["hit"] <= 1e-6
    assert sim.energy() < E0   # the impact dissipated


def test_force_free_spinning_box_keeps_its_energy_and_speed():
    m, pts = box_model(size=CUBE, mass=2.0)   # cube: isotropic inertia, no gyroscopic torque
    m.gravity.linear[:] = 0.0
    sim = Simulator(m, pts, [], np.r_[0, 0, 1.0, 0, 0, 0, 1], v0=np.r_[1.0, 0, 0, 0, 0, 10.0], dt=DT)
    E0, p0 = sim.energy(), sim.q[:3].copy()
    _run(sim, 1.0)
    assert abs(sim.energy() / E0 - 1.0) <= 1e-6
    # straight line at 1 m/s, up to the exp-map step's chord error (ωh)²/24 = 4e-6
    assert abs(np.linalg.norm(sim.q[:3] - p0) - 1.0) <= 1e-5


# ---------------------------------------------------------------- (d) push
@pytest.mark.parametrize("ratio", [0.5, 0.95, 1.1, 1.5])
def test_push_moves_resting_box_iff_force_exceeds_mu_m_g(ratio):
    """A 0.1 s horizontal push at the centre of a slab (0.4 × 0.4 × 0.1 m, μ = 1):
    tipping would need F · sz/2 > m g · sx/2, i.e. F > 4 m g, so only sliding is at stake."""
    size, mass, mu = (0.4, 0.4, 0.1), 5.0, 1.0
    m, pts = box_model(size=size, mass=mass)
    g = _gravity(m)
    q0 = np.r_[0.0, 0.0, 0.5 * size[2], 0, 0, 0, 1]
    sim = Simulator(m, pts, [ground(mu=mu)], q0, dt=DT)
    F = ratio * mu * mass * g
    sim.push("box", [F, 0.0, 0.0], start=0.05, duration=0.1)

    pushed_steps = 0
    for _ in range(1000):
        pushed_steps += any(p.active(sim.t) for p in sim.pushes)
        sim.step(np.zeros(6))
    assert abs(pushed_steps * DT - 0.1) < 1.5 * DT
    d = sim.q[:3] - q0[:3]

    if ratio < 1.0:
        assert np.linalg.norm(d) < 1e-6, f"box moved {np.linalg.norm(d):.3g} m under {ratio} μ m g"
        assert _angle_between(sim.q, q0) < 1e-6
    else:
        # Coulomb: accelerate at (F − μ m g)/m during the push, then decelerate at μ g.
        tp = pushed_steps * DT
        a = (F - mu * mass * g) / mass
        v = a * tp
        expected = 0.5 * a * tp**2 + v**2 / (2 * mu * g)
        # 1 %: the O(h/tp) = 1 % bound on the time-stepping error of these two phases.
        assert abs(d[0] / expected - 1.0) <= 1e-2, f"slid {d[0]:.5f} m, Coulomb predicts {expected:.5f} m"
        assert abs(d[1]) < 1e-6 and abs(d[2]) < 1e-6
        assert np.abs(sim.v).max() < 1e-6, "box should have stopped by t = 1 s"


# ---------------------------------------------------------------- (e) the contact solver binding
@pytest.mark.parametrize("mu", [0.3, 1.5])
def test_contact_solver_impulse_layout_is_tangents_then_normal(mu):
    """One point of mass m hitting the ground at (vx, vy, vz) = (1, -0.5, −2) m/s:
    G = I/m, g = v. The normal impulse stops the fall, λ_n = 2m; the tangential one
    is −m v_t if that fits in the cone, else μ λ_n against v_t. A solver reading
    the normal first (or the cone about another axis) gives something else."""
    from wbc.sim.contact_solver import BACKEND, ContactSolver

    assert BACKEND == ("PGSContactSolver" if hasattr(pin, "PGSContactSolver") else "PGSConstraintSolver")
    m, v = 3.0, np.array([1.0, -0.5, -2.0])
    lam = ContactSolver((mu,)).solve(np.eye(3) / m, v, np.zeros(3))
    lam_n = -m * v[2]
    vt = v[:2]
    lam_t = -m * vt if m * np.linalg.norm(vt) <= mu * lam_n else -mu * lam_n * vt / np.linalg.norm(vt)
    assert np.allclose(lam, np.r_[lam_t, lam_n], rtol=1e-9, atol=1e-9), lam


def test_contact_solver_warm_start_is_not_modified_and_matches_cold_start():
    from wbc.sim.contact_solver import ContactSolver

    rng = np.random.default_rng(4)
    J = rng.normal(size=(12, 6))
    G, g = J @ J.T / 5.0 + 1e-6 * np.eye(12), rng.normal(size=12)
    s = ContactSolver((0.5, 0.8, 0.5, 1.0))
    cold = s.solve(G, g, np.zeros(12))
    warm0 = cold + 0.01
    keep = warm0.copy()
    warm = s.solve(G, g, warm0)
    assert np.array_equal(warm0, keep)
    assert np.allclose(warm, cold, atol=1e-7)


# ---------------------------------------------------------------- (f) actuator saturation
def test_driver_clips_torques_to_limits_and_counts_saturated_steps():
    """Force-free box, the three body torques actuated with a 1 N·m driver: one step of
    ±5 N·m spins it as 1 N·m would (ω = I⁻¹ τ_clipped h), and counts; a command within
    the limits is applied as is and not counted."""
    m, pts = box_model(size=CUBE, mass=2.0)
    m.gravity.linear[:] = 0.0
    inertia = m.inertias[1].inertia
    q0 = np.r_[0, 0, 1.0, 0, 0, 0, 1]
    actuated = np.r_[np.zeros(3, bool), np.ones(3, bool)]
    lim = np.array([1.0, 2.0, np.inf])

    sim = Simulator(m, pts, [], q0, dt=DT, actuated=actuated, tau_limits=lim)
    assert sim.saturated_steps == 0
    sim.step(np.array([5.0, -5.0, 7.0]))           # na actuated torques
    assert sim.saturated_steps == 1
    assert np.allclose(sim.v[3:], np.linalg.solve(inertia, [1.0, -2.0, 7.0]) * DT, rtol=1e-9)

    sim = Simulator(m, pts, [], q0, dt=DT, actuated=actuated, tau_limits=np.r_[np.zeros(3), lim])   # per dof
    sim.step(np.r_[np.zeros(3), 0.5, -1.5, 3.0])   # within the limits
    assert sim.saturated_steps == 0
    assert np.allclose(sim.v[3:], np.linalg.solve(inertia, [0.5, -1.5, 3.0]) * DT, rtol=1e-9)
    sim.step(np.r_[np.zeros(3), -1.5, 0.0, 0.0])
    sim.step(np.r_[np.zeros(3), 0.0, 0.0, 0.0])
    assert sim.saturated_steps == 1

    with pytest.raises(WbcError):
        Simulator(m, pts, [], q0, actuated=actuated, tau_limits=[1.0, 2.0])
    with pytest.raises(WbcError):
        Simulator(m, pts, [], q0, actuated=actuated, tau_limits=[1.0, -1.0, 1.0])



def test_compiled_driver_torque_is_the_masked_clip():
    """The step's driver in one compiled call equals np.clip(np.where(actuated, τ, 0), −lim, lim)
    bit for bit, says whether it clipped anything, and refuses a non-finite actuated torque
    (a NaN on an unactuated dof is dropped, as np.where drops it)."""
    from wbc.sim.contact_rows import driver_torque

    rng = np.random.default_rng(11)
    n = 9
    clipped_seen = 0
    for _ in range(300):
        tau = 20.0 * rng.standard_normal(n)
        act = rng.random(n) < 0.7
        lim = np.where(rng.random(n) < 0.2, np.inf, rng.uniform(1.0, 30.0, n))
        out = np.empty(n)
        finite, clipped = driver_torque(tau, act, lim, out)
        ref = np.where(act, tau, 0.0)
        assert finite and clipped == bool(np.any(np.abs(ref) > lim))
        assert np.array_equal(out, np.clip(ref, -lim, lim))
        finite, clipped = driver_torque(tau, act, np.empty(0), out)
        assert finite and not clipped and np.array_equal(out, ref)
        clipped_seen += clipped or bool(np.any(np.abs(ref) > lim))
    assert clipped_seen > 100
    tau[~act] = np.nan
    assert driver_torque(tau, act, lim, out)[0]
    tau[np.flatnonzero(act)[0]] = np.inf
    assert not driver_torque(tau, act, lim, out)[0]

# ---------------------------------------------------------------- (g) differential drive + contact
def test_differential_drive_base_with_contact_keeps_zero_lateral_velocity():
    """A planar base (10 kg, x, y, yaw; differential drive: no lateral velocity) carrying a
    passive 0.5 m rod (2 kg) hinged 0.4 m above the ground about a horizontal axis at 45°
    to the base's x axis. The rod falls, its tip hits the ground (μ = 0.5) and pushes the
    base along x; the block Gauss-Seidel of contacts and lateral constraint must keep the
    lateral velocity zero while the tip neither sinks nor pulls. At rest the tip carries
    half the rod's weight (moments about the hinge: COM at half the tip's lever), no
    friction (the base is free along its x axis)."""
    m = pin.Model()
    b = m.addJoint(0, pin.JointModelPlanar(), pin.SE3.Identity(), "base")
    m.appendBodyToJoint(b, pin.Inertia(10.0, np.zeros(3), np.diag([0.2, 0.2, 0.3])), pin.SE3.Identity())
    hinge = pin.SE3(pin.exp3(np.array([0.0, 0.0, -np.pi / 4])), np.array([0.0, 0.0, 0.4]))
    a = m.addJoint(b, pin.JointModelRX(), hinge, "rod")
    m.appendBodyToJoint(a, pin.Inertia(2.0, np.array([0.0, 0.25, 0.0]), np.diag([0.04, 0.001, 0.04])),
                        pin.SE3.Identity())
    pts = [("rod", np.array([0.0, 0.5, 0.0]))]
    sim = Simulator(m, pts, [ground(mu=0.5)], pin.neutral(m), dt=DT, actuated=np.r_[False, False, False, True],
                    differential_drive=True)
    worst = {"lat": 0.0, "pen": 0.0, "touched": False}

    def watch(s):
        worst["lat"] = max(worst["lat"], abs(s.v[1]))
        worst["pen"] = max(worst["pen"], -_corners(m, pts, s.q)[0, 2])
        worst["touched"] |= bool(s.point_forces.any())

    for _ in range(3000):
        sim.step(np.zeros(1))
        watch(sim)
    assert worst["touched"] and sim.solver_failures == 0
    assert worst["lat"] <= 1e-9, f"lateral base velocity {worst['lat']:.3g} m/s"
    # 3e-6 m (the impact step); 4e-5 m if the contacts ignored the lateral impulse
    assert worst["pen"] <= 1e-5, f"tip penetration {worst['pen']:.3g} m"
    assert sim.q[0] > 1e-3, "the impact should have pushed the base along its x axis"
    assert np.abs(sim.v).max() < 1e-6
    F, half_weight = sim.point_forces[0], 0.5 * 2.0 * _gravity(m)
    assert abs(F[2] / half_weight - 1.0) <= 1e-3, f"tip force {F} N, half the rod's weight {half_weight} N"
    assert np.linalg.norm(F[:2]) <= 1e-3 * half_weight
