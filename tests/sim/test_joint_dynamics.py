"""The URDF's joint damping and dry friction in both simulators (``joint_dynamics=True``).

One revolute joint about the vertical (gravity exerts no torque on it), written as a URDF in
the test: inertia I = I_zz + m r² about the axis, ``<dynamics damping="d" friction="f"/>``.
The closed forms it must reproduce:

- free decay under damping: q̇(t) = q̇₀ e^{−d t / I}; wbc.sim's implicit step gives exactly
  q̇_n = q̇₀ (I / (I + h d))ⁿ, within t h (d/I)² / 2 (relative) of the exponential;
- a torque below f: the joint stays at rest (wbc.sim to machine precision; MuJoCo's soft
  friction constraint creeps, bounded here);
- a torque τ above f: q̈ = (τ − f) / I;
- a 20000 N·m·s/rad damper (PR2's torso) at h = 1 ms: monotone decay, no overshoot.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.robot.loader import load_robot
from wbc.sim import Simulator
from wbc.sim.joint_dynamics import box_qp

MASS, R, IZZ = 2.0, 0.25, 0.02          # kg, m (CoM off the axis), kg·m² about the CoM
INERTIA = IZZ + MASS * R * R            # kg·m² about the joint axis: 0.145
H = 1e-3


def _robot(tmp_path, damping: float, friction: float):
    """A fixed-base robot of one vertical revolute joint with the URDF's dynamics."""
    urdf = tmp_path / f"joint_{damping:g}_{friction:g}.urdf"
    urdf.write_text(f"""<robot name="one_joint">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><origin xyz="{R} 0 0"/><mass value="{MASS}"/>
    <inertia ixx="0.001" iyy="0.02" izz="{IZZ}" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-100" upper="100" effort="100" velocity="100"/>
    <dynamics damping="{damping}" friction="{friction}"/></joint>
</robot>""")
    yaml = urdf.with_suffix(".yaml")
    yaml.write_text(f"name: one_joint\nurdf: {urdf.name}\nroot: fixed\n")
    return load_robot(yaml)


def _sim(kind: str, robot, v0: float, joint_dynamics: bool = True):
    q0 = np.zeros(1)
    if kind == "pinocchio":
        return Simulator.for_robot(robot, [], q0=q0, dt=H, joint_dynamics=joint_dynamics) if v0 == 0.0 else \
            _with_velocity(Simulator.for_robot(robot, [], q0=q0, dt=H, joint_dynamics=joint_dynamics), v0)
    pytest.importorskip("mujoco")
    from wbc.sim.mujoco_sim import MujocoSimulator

    return MujocoSimulator.for_robot(robot, [], q0=q0, v0=np.array([v0]), dt=H, joint_limits=False,
                                     joint_dynamics=joint_dynamics)


def _with_velocity(sim, v0: float):
    sim.v = np.array([v0])
    return sim


def _run(sim, tau: float, n: int) -> np.ndarray:
    """Joint velocities after each of n steps under the constant torque tau (N·m)."""
    out = np.empty(n)
    for k in range(n):
        sim.step(np.array([tau]))
        out[k] = sim.v[0]
    return out


def test_model_inertia_is_the_closed_form(tmp_path):
    robot = _robot(tmp_path, 0.3, 0.0)
    assert robot.M[0, 0] == pytest.approx(INERTIA, rel=1e-12)
    assert robot.model.damping[0] == 0.3


@pytest.mark.parametrize("kind", ["pinocchio", "mujoco"])
def test_free_decay_matches_the_damping_rate(tmp_path, kind):
    d, v0, n = 0.3, 2.0, 1000                      # d/I = 2.07 /s, 1 s
    v = _run(_sim(kind, _robot(tmp_path, d, 0.0), v0), 0.0, n)
    k = np.arange(1, n + 1)
    discrete = v0 * (INERTIA / (INERTIA + H * d)) ** k
    # both simulators integrate the damper implicitly (MuJoCo's Euler does): the same sequence
    assert np.abs(v - discrete).max() <= 1e-10 * v0
    exact = v0 * np.exp(-d * H * k / INERTIA)
    bound = (H * k) * H * (d / INERTIA) ** 2 / 2 * 1.01 + 1e-12
    assert np.all(np.abs(v / exact - 1.0) <= bound)
    rate = -math.log(v[-1] / v0) / (n * H)
    assert rate == pytest.approx(d / INERTIA, rel=2e-3)


def test_simulators_agree_on_the_decay(tmp_path):
    robot = _robot(tmp_path, 0.3, 0.0)
    ours = _run(_sim("pinocchio", robot, 2.0), 0.0, 1000)
    theirs = _run(_sim("mujoco", robot, 2.0), 0.0, 1000)
    assert np.abs(ours - theirs).max() <= 1e-10


@pytest.mark.parametrize("kind", ["pinocchio", "mujoco"])
def test_stiff_damper_decays_monotonically(tmp_path, kind):
    v = _run(_sim(kind, _robot(tmp_path, 20000.0, 0.0), 1.0), 5.0, 200)
    assert np.all(np.isfinite(v)) and np.all(v > 0) and np.all(np.diff(v) <= 0)
    # the step's fixed point under τ = 5 N·m: the damper's terminal velocity τ/d
    assert v[-1] == pytest.approx(5.0 / 20000.0, rel=1e-6)


@pytest.mark.parametrize("kind", ["pinocchio", "mujoco"])
def test_torque_below_friction_leaves_the_joint_at_rest(tmp_path, kind):
    f, tau, t = 0.5, 0.4, 0.5
    sim = _sim(kind, _robot(tmp_path, 0.0, f), 0.0)
    v = _run(sim, tau, round(t / H))
    # without joint dynamics the same torque turns it at τ / I
    free = _sim(kind, _robot(tmp_path, 0.0, f), 0.0, joint_dynamics=False)
    assert _run(free, tau, round(t / H))[-1] == pytest.approx(tau / INERTIA * t, rel=1e-9)
    assert free.q[0] == pytest.approx(tau / INERTIA * t * t / 2, rel=1e-2)       # 0.34 rad
    if kind == "pinocchio":          # rigid dry friction: exactly at rest
        assert sim.q[0] == 0.0 and np.all(v == 0.0)
    else:
        # MuJoCo's frictionloss is a soft constraint: the joint creeps at a steady velocity
        # (7.3e-3 rad/s per N·m here, as a 137 N·m·s/rad damper would), it never accelerates
        assert abs(sim.q[0]) < 0.01 * free.q[0]
        assert abs(v[-1] - v[249]) < 1e-3 * abs(v[-1])      # (frictionless: v doubles)


@pytest.mark.parametrize("kind", ["pinocchio", "mujoco"])
def test_torque_above_friction_accelerates_at_the_net_torque(tmp_path, kind):
    f, tau, n = 0.5, 0.8, 500
    v = _run(_sim(kind, _robot(tmp_path, 0.0, f), 0.0), tau, n)
    a = (tau - f) / INERTIA
    # from the first step on it slides: v_k = a h k (MuJoCo's first steps are soft, 1e-3)
    tol = 1e-9 if kind == "pinocchio" else 1e-3
    assert v[-1] == pytest.approx(a * n * H, rel=tol)
    assert np.diff(v[10:]) == pytest.approx(np.full(n - 11, a * H), rel=tol)


def test_sliding_joint_stops_and_sticks(tmp_path):
    """Dry friction decelerates a spinning joint at f/I until it stops, then holds it."""
    f, v0 = 0.5, 1.0
    sim = _sim("pinocchio", _robot(tmp_path, 0.0, f), v0)
    v = _run(sim, 0.0, 600)
    t_stop = v0 * INERTIA / f                               # 0.29 s
    k = int(t_stop / H)
    assert v[: k - 1] == pytest.approx(v0 - f / INERTIA * H * np.arange(1, k), rel=1e-9)
    assert np.abs(v[k + 1:]).max() <= 1e-15                   # at rest to rounding


def test_off_is_the_frictionless_step(tmp_path):
    """With joint_dynamics off (the default) nothing of the URDF's dynamics acts."""
    sim = Simulator.for_robot(_robot(tmp_path, 0.3, 0.5), [], q0=np.zeros(1), dt=H)
    assert sim.joint_dynamics is None
    v = _run(sim, 0.1, 100)
    assert v[-1] == pytest.approx(0.1 / INERTIA * 0.1, rel=1e-12)


def test_box_qp_meets_its_optimality_conditions():
    """The friction impulses' bound-constrained QP: |λ| ≤ b, and the constrained velocity
    Gλ + g is 0 where λ is inside, ≥ 0 at −b, ≤ 0 at +b (random SPD problems, warm or cold)."""
    rng = np.random.default_rng(3)
    for trial in range(300):
        n = int(rng.integers(1, 25))
        A = rng.normal(size=(n, n))
        G = A @ A.T + 1e-3 * np.eye(n)
        g = rng.normal(size=n) * 10.0 ** rng.uniform(-2, 2)
        b = rng.uniform(0.01, 1.0, n)
        warm = rng.uniform(-1.5, 1.5, n) * b if trial % 2 else np.zeros(n)
        lam = box_qp(G, g, b, warm)
        grad = G @ lam + g
        tol = 1e-9 * (np.abs(G).max() * b.max() + np.abs(g).max())
        assert np.all(np.abs(lam) <= b)
        upper, lower = lam >= b, lam <= -b
        inside = ~(upper | lower)
        assert np.all(np.abs(grad[inside]) <= tol)
        assert np.all(grad[upper] <= tol) and np.all(grad[lower] >= -tol)


def test_friction_with_contacts_meets_the_friction_law():
    """Talos on the ground under its default posture's gravity torques, with joint dynamics:
    after each step each friction impulse is within ±h f and a joint whose impulse is inside
    the bound does not move; and the block Gauss-Seidel of one step converged to a point where
    both laws hold at once: the contacts' PGS, given the final friction impulses, returns the
    contact impulses it ended with (and the friction QP, given those, the friction impulses)."""
    import pinocchio as pin

    from wbc.sim import ground
    from wbc.sim.joint_dynamics import MAX_SWEEPS

    robot = load_robot("talos")
    sim = Simulator.for_robot(robot, [ground()], dt=H, joint_dynamics=True, tau_limits=robot.tau_max)
    jd, m, d = sim.joint_dynamics, robot.model, sim.data
    robot.update(robot.q_default, np.zeros(robot.nv))
    tau = robot.h.copy()
    tau[: robot.n_root] = 0.0             # the joints' gravity torques: Talos sags onto its soles
    for _ in range(20):
        sim.step(tau)
        lam, b = jd.lam_f, H * jd.friction[jd.friction_idx]
        assert np.all(np.abs(lam) <= b)
        stuck = np.abs(lam) < b * (1 - 1e-9)
        assert np.abs(sim.v[jd.friction_idx[stuck]]).max(initial=0.0) <= 1e-8
        assert 1 <= jd.sweeps < MAX_SWEEPS
    assert stuck.any()
    # one more step's impulse problem, solved as the simulator does, then checked as a fixed point
    pin.computeJointJacobians(m, d, sim.q)
    pin.updateFramePlacements(m, d)
    rows, _, depths, mus, _ = sim._contact_rows()
    Minv, a = jd.free_motion(m, d, sim.q, sim.v, tau, None, H)
    v_free = sim.v + H * a
    J = np.vstack(rows)
    g = J @ v_free
    g[2::3] -= np.where(np.array(depths) > 0, sim.baumgarte * np.array(depths), depths) / H
    pgs = sim._pgs_for(tuple(mus))
    _, lam_c = jd.friction_impulses(Minv, v_free, H, (J, g, pgs.solve, np.zeros_like(g)))
    assert jd.sweeps > 1 and lam_c[2::3].sum() > 0.0
    f = jd.friction_idx
    again = pgs.solve(J @ Minv @ J.T, g + J @ Minv[:, f] @ jd.lam_f, lam_c)
    assert np.abs(again - lam_c).max() <= 1e-6 * np.abs(lam_c).max()
    lam_f = box_qp(Minv[np.ix_(f, f)], v_free[f] + (Minv @ J.T @ lam_c)[f], H * jd.friction[f], jd.lam_f)
    assert np.abs(lam_f - jd.lam_f).max() <= 1e-6 * H * jd.friction[f].max()


@pytest.mark.parametrize("on", [False, True])
def test_mujoco_model_takes_the_urdf_values_when_on(on):
    """MuJoCo's dof_damping and dof_frictionloss are pinocchio's (the URDF's) with joint
    dynamics on, zero with it off (Talos: 1 N·m·s/rad and 1 N·m on 20 joints)."""
    pytest.importorskip("mujoco")
    from wbc.sim.backends import make_simulator

    robot = load_robot("talos")
    sim = make_simulator("mujoco", robot, [], joint_dynamics=on, dt=H)
    mm, m = sim.mj_model, robot.model
    assert mm.dof_damping[sim._vm] == pytest.approx(m.damping[sim._vi] if on else 0.0, abs=0.0)
    assert mm.dof_frictionloss[sim._vm] == pytest.approx(m.friction[sim._vi] if on else 0.0, abs=0.0)
    assert not mm.dof_damping[sim._root_v: sim._root_v + 6].any()
    assert (np.count_nonzero(mm.dof_frictionloss) == 20) == on


def test_make_simulator_and_scenario_flag(tmp_path):
    from wbc.errors import ConfigError
    from wbc.scenario.loader import load_config
    from wbc.sim.backends import make_simulator

    robot = _robot(tmp_path, 0.3, 0.5)
    assert make_simulator("pinocchio", robot, [], joint_dynamics=True).joint_dynamics is not None
    assert make_simulator("pinocchio", robot, []).joint_dynamics is None
    sc = tmp_path / "bad.yaml"
    sc.write_text(f"robot: {tmp_path / 'joint_0.3_0.5.yaml'}\nenvironment: []\njoint_dynamics: 1\n"
                  "stack:\n  - - {type: posture, kp: 1.0}\n")
    with pytest.raises(ConfigError) as err:
        load_config(sc)
    assert "bad.yaml:3: joint_dynamics: must be true or false, got 1" in str(err.value)
    sc.write_text(sc.read_text().replace("joint_dynamics: 1", "joint_dynamics: true"))
    assert load_config(sc).joint_dynamics is True
