"""The joints-only copy of a model (:func:`wbc.sim.bodies.dynamics_model`) that the own simulator's
M⁻¹ and ABA run on: the same numbers as on the full model, bit for bit, on every bundled robot."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.robot.loader import available_robots, load_robot
from wbc.scenario.loader import load_config
from wbc.sim.backends import make_simulator
from wbc.sim.bodies import binding_copies_model, dynamics_model


@pytest.mark.parametrize("name", available_robots())
def test_minverse_and_aba_bit_for_bit_on_the_joints_only_copy(name):
    """computeMinverse and aba (without and with external forces) on 40 random states give the
    same bits on the copy as on the robot's model; the copy has the same joints and no frame."""
    robot = load_robot(name)
    m = robot.model
    lean = dynamics_model(m)
    assert lean.nframes <= 1 < m.nframes
    assert (lean.njoints, lean.nq, lean.nv) == (m.njoints, m.nq, m.nv)
    assert list(lean.idx_qs) == list(m.idx_qs) and list(lean.idx_vs) == list(m.idx_vs)
    d, ld = m.createData(), lean.createData()
    rng = np.random.default_rng(7)
    for _ in range(40):
        q = pin.integrate(m, robot.q_default, rng.normal(0.0, 0.7, m.nv))
        v, tau = rng.normal(0.0, 1.0, m.nv), rng.normal(0.0, 20.0, m.nv)
        fext = [pin.Force(rng.normal(0.0, 10.0, 6)) for _ in range(m.njoints)]
        assert pin.computeMinverse(lean, ld, q).tobytes() == pin.computeMinverse(m, d, q).tobytes()
        assert pin.aba(lean, ld, q, v, tau).tobytes() == pin.aba(m, d, q, v, tau).tobytes()
        assert pin.aba(lean, ld, q, v, tau, fext).tobytes() == pin.aba(m, d, q, v, tau, fext).tobytes()


@pytest.mark.parametrize("name", available_robots())
def test_the_copy_leaves_the_topology_tables_empty_only_where_the_bindings_copy_it(name):
    """On pinocchio 3 (its computeMinverse and aba bindings copy the model at every call) the copy
    holds no children, supports nor subtree lists (what its per-call copy costs), and ABA's and
    M⁻¹'s bits are still the full model's (the test above) on a Data built from it; on pinocchio 4
    (no copy) the tables are the model's."""
    m = load_robot(name).model
    lean = dynamics_model(m)
    tables = ("children", "supports", "mimic_joint_supports", "subtrees")
    assert binding_copies_model() == pin.__version__.startswith("3.")
    if pin.__version__.startswith("3."):
        assert all(len(getattr(lean, t)) == 0 for t in tables if hasattr(lean, t))
        assert list(lean.parents) == list(m.parents)
    else:
        assert all(list(map(list, getattr(lean, t))) == list(map(list, getattr(m, t))) for t in tables if hasattr(m, t))


def test_the_copy_follows_the_models_parameters(talos):
    """A changed mass, armature or gravity in the model (a perturbed model given to the simulator)
    is in the copy: its M⁻¹ and free fall change with them."""
    m = pin.Model(talos.model)
    m.inertias[5] = pin.Inertia(m.inertias[5].mass * 1.5, m.inertias[5].lever, m.inertias[5].inertia)
    m.armature[10] = 0.3
    m.gravity.linear = np.array([0.0, 0.0, -1.62])
    lean = dynamics_model(m)
    q, v, tau = talos.q_default, np.zeros(m.nv), np.zeros(m.nv)
    assert pin.computeMinverse(lean, lean.createData(), q).tobytes() == pin.computeMinverse(m, m.createData(), q).tobytes()
    assert pin.aba(lean, lean.createData(), q, v, tau).tobytes() == pin.aba(m, m.createData(), q, v, tau).tobytes()
    assert not np.array_equal(pin.computeMinverse(lean, lean.createData(), q),
                              pin.computeMinverse(talos.model, talos.model.createData(), q))


def test_the_simulator_steps_as_with_the_full_model(talos):
    """120 steps of the simulator (contacts, M⁻¹ on the copy), then 20 with a push (ABA with
    external forces on the copy) equal a replay whose M⁻¹ and ABA run on the full model."""
    sc = load_config("talos_balance")
    sims = [make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max) for _ in range(2)]
    full = sims[1]
    full._dyn_model, full._dyn_data = full.model, full.model.createData()
    for sim in sims:
        sim.push("torso_2_link", [40.0, 10.0, 0.0], 0.12, 0.02)
    tau = pin.rnea(talos.model, talos.model.createData(), talos.q_default, np.zeros(talos.model.nv),
                   np.zeros(talos.model.nv))
    for _ in range(140):
        for sim in sims:
            sim.step(tau)
        assert sims[0].q.tobytes() == full.q.tobytes() and sims[0].v.tobytes() == full.v.tobytes()
    assert not np.array_equal(sims[0].q, talos.q_default)


def test_free_motion_in_one_call_is_the_two_calls():
    """``free_motion`` (one compiled call) gives free_acceleration's then free_velocity's bits,
    with and without a free-flyer root, M⁻¹ given by its upper triangle (computeMinverse's)."""
    from wbc.sim import contact_rows as cr

    rng = np.random.default_rng(3)
    for k in range(300):
        n = 6 + k % 30
        A = rng.normal(size=(n, n))
        Minv = np.triu(A @ A.T + n * np.eye(n))
        tau, nle, v = rng.normal(0, 20, n), rng.normal(0, 20, n), rng.normal(0, 2, n)
        ff = bool(k % 2)
        got = cr.free_motion(Minv.copy(), tau, nle, v, 1e-3, ff)
        want = cr.free_velocity(v, cr.free_acceleration(Minv.copy(), tau, nle), 1e-3, ff)
        assert all(a.tobytes() == b.tobytes() for a, b in zip(got, want, strict=True))
        full = Minv + np.triu(Minv, 1).T          # the lower triangle filled: what the step integrates
        assert np.allclose(got[0], v + 1e-3 * (full @ (tau - nle)), rtol=1e-12, atol=1e-12)
