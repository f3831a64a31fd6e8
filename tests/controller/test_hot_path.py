"""The optimised paths of the control cycle give what the plain computations give.

- the Gram-matrix (Cholesky) path of the cascade = the SVD path (tall, well-conditioned levels),
  and is refused when the level is ill-conditioned or rank deficient;
- the reused per-level buffers = rows stacked afresh, across cycles and stack changes;
- the cascade started from the state's nominal point (the contacts carrying gravity) keeps
  every fully solvable level met, on average never does worse on the sacrificed ones than
  the start from 0, and needs fewer QPs;
- the simulator's contact Jacobians (one joint Jacobian per joint) = pinocchio's frame
  Jacobian of an operational frame placed at each contact point.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.helpers.reference_hqp import reference_solve_levels
from tests.helpers.reference_projection import reference_solve_accelerations, sns_level
from tests.helpers.stacks import random_state, randomise_targets, same_random_case, talos_stack
from wbc.problem.result import singular_values
from wbc.sim.environment import ground
from wbc.sim.simulator import Simulator
from wbc.solvers.cascade import Cascade, Damping
from wbc.solvers.kernels import factorizations as routes
from wbc.solvers.kernels.forces import nnls_on_support
from wbc.solvers.kernels.records import hint_table
from wbc.solvers.kernels.sns_run import projection_prefix
from wbc.stack import assemble_level


def _cascade_with_free(n: int, k: int, rng, d: Damping) -> Cascade:
    """A cascade over R^(n+k) whose first level (k random rows) leaves n free directions:
    a random orthonormal Z, as a higher level would leave."""
    cas = Cascade(n + k)
    B = rng.standard_normal((n + k, k))
    cas.commit(cas.ls_step(B.T, rng.standard_normal(k), d))
    assert cas.dof == n
    return cas


def _svd_step(cas: Cascade, A, b, d):
    """The same step by the SVD route."""
    return cas.route_step(A, b, d, routes.SVD)


@pytest.mark.parametrize("m,n", [(18, 50), (12, 29), (8, 9), (3, 32)])
def test_qr_path_equals_svd_path(m, n):
    """(3, 32): few rows over many free directions, where the QR route forms the next basis as
    (Z Q)[:, m:] instead of Z·Q[:, m:] (:func:`~wbc.solvers.kernels.factorizations._qr`)."""
    rng = np.random.default_rng(m * 100 + n)
    d = Damping()
    for _trial in range(20):
        cas = _cascade_with_free(n, 4, rng, d)
        A = rng.standard_normal((m, n + 4))
        b = rng.standard_normal(m)
        q = cas.route_step(A, b, d, routes.QR)
        s = _svd_step(cas, A, b, d)
        assert q is not None and q.rank == s.rank == m
        np.testing.assert_allclose(q.z, s.z, atol=1e-12 * max(1.0, np.linalg.norm(s.z)))
        smin, smax = singular_values(q.R)       # worked out on demand from R
        assert abs(smin - s.sigma_min) <= 1e-12 * s.sigma_max and abs(smax - s.sigma_max) <= 1e-12 * s.sigma_max
        # the same null space (bases differ by a rotation): equal projectors, orthonormal
        np.testing.assert_allclose(q.Z_next @ q.Z_next.T, s.Z_next @ s.Z_next.T, atol=1e-12)
        np.testing.assert_allclose(q.Z_next.T @ q.Z_next, np.eye(n - m), atol=1e-12)


def test_qr_path_refuses_rank_deficient_and_near_singular_levels():
    rng = np.random.default_rng(3)
    cas = Cascade(30)
    U, _ = np.linalg.qr(rng.standard_normal((10, 10)))
    V, _ = np.linalg.qr(rng.standard_normal((30, 10)))
    for smin in (0.0, 1e-12, 5e-4):          # singular, rank-deficient, below the damping threshold
        A = U @ np.diag(np.r_[np.ones(9), smin]) @ V.T
        assert cas.route_step(A, rng.standard_normal(10), Damping(), routes.QR) is None


@pytest.mark.parametrize("m,n", [(32, 26), (38, 14), (12, 12), (40, 3)])
def test_gram_path_equals_svd_path(m, n):
    rng = np.random.default_rng(m * 100 + n)
    d = Damping()
    for _trial in range(20):
        cas = _cascade_with_free(n, 5, rng, d)
        A = rng.standard_normal((m, n + 5))
        b = rng.standard_normal(m)
        g = cas.ls_step(A, b, d)
        s = _svd_step(cas, A, b, d)
        assert g.Z_next.shape == s.Z_next.shape == (n + 5, 0)
        assert g.rank == s.rank == n
        # normal equations lose at most κ² ε ≈ 1e-8 relative at the accepted κ ≤ 1e4
        assert np.linalg.norm(g.z - s.z) <= 1e-8 * max(1.0, np.linalg.norm(s.z))
        smin, smax = (g.sigma_min, g.sigma_max) if g.R is None else singular_values(g.R)
        assert abs(smin - s.sigma_min) <= 1e-8 * s.sigma_max
        assert abs(smax - s.sigma_max) <= 1e-10 * s.sigma_max


def test_gram_path_refuses_ill_conditioned_and_rank_deficient_levels():
    rng = np.random.default_rng(0)
    cas = Cascade(10)
    U, _ = np.linalg.qr(rng.standard_normal((20, 10)))
    V, _ = np.linalg.qr(rng.standard_normal((10, 10)))
    for smin in (1e-5, 1e-12, 0.0):         # κ = 1e5, 1e12, singular
        A = U @ np.diag(np.r_[np.ones(9), smin]) @ V.T
        assert cas.route_step(A, rng.standard_normal(20), Damping(), routes.GRAM) is None
        step = cas.ls_step(A, rng.standard_normal(20), Damping())
        assert step.rank == (10 if smin > 1e-9 else 9)      # another route decides the rank
        assert step.route != routes.GRAM
    A = U @ np.diag(np.r_[np.ones(9), 1e-3]) @ V.T   # κ = 1e3: accepted
    assert cas.route_step(A, rng.standard_normal(20), Damping(), routes.GRAM) is not None


def test_level_buffers_equal_rows_stacked_afresh():
    robot = wbc.load_robot("talos")
    stack = talos_stack()
    ctrl = wbc.Controller(robot, stack)
    rng = np.random.default_rng(1)
    for k in range(6):
        q, v = random_state(robot, rng)
        robot.update(q, v)
        randomise_targets(stack, robot, rng)
        ctrl.solve(q, v)
        if k == 3:      # a structural change: the buffers must be rebuilt, not reused wrongly
            stack.remove("left_hand")
            ctrl.solve(q, v)
        layout = ctrl.layout
        extra = ctrl._internal_constraints(layout)
        reused = stack.assemble(robot, layout, extra)
        groups = [list(extra) + list(stack.levels[0])] + [list(lvl) for lvl in stack.levels[1:]]
        for lvl, tasks in zip(reused, groups):
            fresh = assemble_level(lvl.index, tasks, robot, layout)
            for name in ("A", "b", "C", "lo", "hi"):
                np.testing.assert_array_equal(getattr(lvl, name), getattr(fresh, name), err_msg=name)
            for a, f in zip(lvl.inequalities(layout.nx), fresh.inequalities(layout.nx)):
                np.testing.assert_array_equal(a, f)
            assert lvl.eq_slices == fresh.eq_slices and lvl.in_slices == fresh.in_slices
            if fresh.box is None:
                assert lvl.box is None
            else:
                for a, f in zip(lvl.box, fresh.box):
                    np.testing.assert_array_equal(a, f)


def _moving_run(warm: bool, cycles: int = 600):
    from tests.helpers.stacks import DT, bench_stack, moving_targets

    robot = wbc.load_robot("talos")
    stack = bench_stack()
    ctrl = wbc.Controller(robot, stack, solver="hqp", warm_start=warm)
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    set_targets = moving_targets(robot, stack)
    res, qps = [], 0
    for k in range(cycles):
        set_targets(k * DT)
        sol = ctrl.solve(q, v)
        assert sol.status == "ok"
        res.append(sol.residuals)
        qps += sol.qp_count
        v = v + sol.qdd * DT
        q = pin.integrate(robot.model, q, v * DT)
    return np.array(res), qps


def test_warm_started_cascade_keeps_optima_and_saves_qps():
    """``warm_start``: the cascade starts from the state's nominal point (never from the
    previous cycle) instead of 0."""
    warm, qp_warm = _moving_run(True)
    cold, qp_cold = _moving_run(False)
    print(f"\nmean residual per level: warm {np.round(warm.mean(0), 4)}, cold {np.round(cold.mean(0), 4)}; "
          f"QPs {qp_warm} vs {qp_cold}")
    # contacts + limits, CoM and hands are solvable: met (to the QPs' accuracy) either way,
    # and the nominal start is not worse on them. (Each QP keeps its higher rows a margin
    # from their bounds, and from 0 there are 1.6 per cycle with this trajectory's CoPs on
    # their cop_margin rectangle: up to 1.3e-3 m/s² on the hands.)
    assert warm[:, :3].max() < 1e-3 and cold[:, :3].max() < 2e-3
    assert warm[:, :3].mean() <= cold[:, :3].mean() + 1e-9
    # the sacrificed levels (posture, force regularisation): no worse on average
    assert np.all(warm.mean(0)[3:] <= 1.01 * cold.mean(0)[3:])
    assert qp_warm < qp_cold


def test_simulator_contact_jacobians_equal_frame_jacobians():
    robot = wbc.load_robot("talos")
    sim = Simulator.for_robot(robot, [ground()])
    rng = np.random.default_rng(2)
    model = pin.Model(sim.model)
    fids = []
    for i, (jid, r) in enumerate(sim.points):
        fids.append(model.addFrame(pin.Frame(f"pt{i}", jid, 0, pin.SE3(np.eye(3), r), pin.FrameType.OP_FRAME)))
    data = model.createData()
    for _ in range(5):
        # the default posture, 1 mm low and tilted by up to ~0.6°: soles in or near the ground
        q = robot.q_default.copy()
        q[2] -= 0.001
        R = pin.rpy.rpyToMatrix(*(0.01 * rng.standard_normal(3)))
        q[3:7] = pin.Quaternion(R).coeffs()
        sim.q = q
        pin.computeJointJacobians(sim.model, sim.data, q)
        pin.updateFramePlacements(sim.model, sim.data)
        rows, frames, depths, mus, ids = sim._contact_rows()
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        assert ids.size, "no point in contact"
        for row, R, dep, i in zip(rows.reshape(-1, 3, model.nv), frames, depths, ids):
            J = pin.getFrameJacobian(model, data, fids[i], pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]
            np.testing.assert_allclose(row, R.T @ J, atol=1e-12)
            assert dep == pytest.approx(-data.oMf[fids[i]].translation[2], abs=1e-12)


@pytest.mark.parametrize("m,n,rank", [(32, 17, 11), (12, 29, 9), (6, 6, 3), (40, 20, 19)])
def test_cod_route_equals_svd_path_on_rank_deficient_levels(m, n, rank):
    """A posture level leaves the internal contact forces free: its rows have exact null
    directions. The complete orthogonal decomposition gets the SVD's rank, step and null
    space, and the cascade takes it when the level's first route refuses."""
    rng = np.random.default_rng(m * 1000 + n * 10 + rank)
    d = Damping()
    for _trial in range(20):
        cas = _cascade_with_free(n, 3, rng, d)
        A = rng.standard_normal((m, rank)) @ rng.standard_normal((rank, n)) @ cas.Z.T
        b = rng.standard_normal(m)
        c = cas.route_step(A, b, d, routes.COD)
        s = _svd_step(cas, A, b, d)
        assert c is not None and c.rank == s.rank == rank
        smin, smax = singular_values(c.R)       # σ of J̄_k, on demand, from T
        assert abs(smin - s.sigma_min) <= 1e-9 * s.sigma_max and abs(smax - s.sigma_max) <= 1e-9 * s.sigma_max
        np.testing.assert_allclose(c.z, s.z, atol=1e-9 * max(1.0, np.linalg.norm(s.z)))
        np.testing.assert_allclose(c.Z_next @ c.Z_next.T, s.Z_next @ s.Z_next.T, atol=1e-9)
        np.testing.assert_allclose(c.Z_next.T @ c.Z_next, np.eye(n - rank), atol=1e-12)
        assert cas.ls_step(A, b, d).route == routes.COD


def test_cod_route_refuses_what_it_cannot_prove():
    """Below the damping threshold, or a singular value between the rank tolerance and
    the certificate's reach: the SVD decides."""
    rng = np.random.default_rng(5)
    U, _ = np.linalg.qr(rng.standard_normal((20, 10)))
    V, _ = np.linalg.qr(rng.standard_normal((10, 10)))
    cas = Cascade(10)
    for smin in (5e-4, 1e-8):
        A = U @ np.diag(np.r_[np.ones(7), smin, 0.0, 0.0]) @ V.T
        b = rng.standard_normal(20)
        assert cas.route_step(A, b, Damping(), routes.COD) is None
        step = cas.ls_step(A, b, Damping())
        assert step.route == routes.SVD and step.rank == 8


def test_compiled_joint_acceleration_bounds_match_the_docstring_formula():
    """JointLimits' compiled bounds = the three limits of its docstring written out joint
    by joint in plain Python, at random states inside and outside the limits (crossed
    bounds collapse to their midpoint)."""
    robot = wbc.load_robot("talos")
    task = wbc.tasks.JointLimits(margin=0.01)
    rng = np.random.default_rng(7)
    dt, T, amax, mg = task.dt, task.horizon, task.max_acceleration, task.margin
    qi = task._indices(robot)[0]
    crossed = 0
    for trial in range(20):
        q, v = random_state(robot, rng)
        v = v * (5.0 if trial % 2 else 1.0)
        if trial % 3 == 2:          # a few joints past their upper limit, moving on outwards
            q[qi[:6]] = robot.q_max[qi[:6]] + 0.05
            v[:] = 0.0
            v[qi[:6] - 1] = 3.0
        robot.update(q, v)
        vi, lo, hi = task.bounds(robot)
        assert len(vi) == len(qi) > 0
        for k, (iq, iv) in enumerate(zip(qi, vi)):
            qk, vk = q[iq], v[iv]

            def upper(lim, x, xd, vmax):
                d = max(lim - x - xd * dt, 0.0)
                return min((vmax - xd) / dt, 2.0 * (lim - x - xd * T) / T**2, (np.sqrt(2 * amax * d) - xd) / dt)

            u = upper(robot.q_max[iq] - mg, qk, vk, robot.v_max[iv])
            low = -upper(-robot.q_min[iq] - mg, -qk, -vk, robot.v_max[iv])
            if low > u:
                u = low = 0.5 * (u + low)
                crossed += 1
            assert lo[k] == pytest.approx(low, rel=1e-12, abs=1e-9)
            assert hi[k] == pytest.approx(u, rel=1e-12, abs=1e-9)
    assert crossed > 0
    # TIAGo's planar base: velocity-only coordinates after the joints, (±v_max − v)/dt; the
    # index array is the same object every cycle (the row buffer then skips comparing it)
    tiago = wbc.load_robot("tiago")
    task = wbc.tasks.JointLimits()
    q, v = random_state(tiago, rng)
    tiago.update(q, v)
    vi, lo, hi = task.bounds(tiago)
    qi, vj, extra = task._indices(tiago)[:3]
    assert len(extra) > 0 and vi.tolist() == vj.tolist() + extra.tolist()
    np.testing.assert_allclose(lo[len(vj):], (-tiago.v_max[extra] - v[extra]) / task.dt, rtol=1e-15)
    np.testing.assert_allclose(hi[len(vj):], (tiago.v_max[extra] - v[extra]) / task.dt, rtol=1e-15)
    tiago.update(q, 2.0 * v)
    assert task.bounds(tiago)[0] is vi


def test_a_qp_answer_outside_its_rows_is_not_accepted():
    """A back-end that reports "optimal" for a point outside its rows (daqp did, on an
    ε-regularised rank-deficient level) is overruled: the other back-end answers."""
    from wbc.solvers.backends import QPResult
    from wbc.solvers.hqp import HierarchicalQP

    class Liar:
        name, psd_ok = "liar", False

        def solve(self, H, g, C, lo, hi, key=None, feasible=False):
            return QPResult(np.full(H.shape[0], 10.0), True, "optimal")

    hqp = HierarchicalQP(backend=Liar(), certify=False)     # the back-ends themselves
    rng = np.random.default_rng(2)
    H = np.eye(4)
    g = rng.standard_normal(4)
    C = np.eye(4)
    lo, hi = -np.ones(4), np.ones(4)
    z, _, status = hqp._solve_qp(H, g, (C, lo, hi), (4, 0, 1e-6), "t")
    assert z is not None and np.all(np.abs(z) <= 1 + 1e-6)
    np.testing.assert_allclose(z, np.clip(-g, -1, 1), atol=1e-6)     # the fallback's true optimum
    hqp._fb = Liar()                                                  # nobody honest left
    z, _, status = hqp._solve_qp(H, g, (C, lo, hi), (4, 0, 1e-6), "t")
    assert z is None and "violated by" in status


def test_weighted_solver_does_not_damp_a_level_for_its_small_weight():
    """The soft hierarchy folds level k with weight 1e-3^(k−1): a well-conditioned level of
    weight 1e-9 has σ ≈ 3e-5, under the singularity threshold. It must be solved, not
    damped away: the weighted solution is the plain weighted least squares. (Damped, the
    torso orientation of talos_reach drifted 0.47 rad and the robot tipped over.)"""
    from wbc.problem.rows import Level
    from wbc.solvers.weighted import WeightedQP

    rng = np.random.default_rng(11)
    n = 8
    blocks = [rng.standard_normal((3, n)), rng.standard_normal((2, n)), rng.standard_normal((2, n)), np.eye(n)]
    targets = [rng.standard_normal(len(A)) for A in blocks]
    none = (np.zeros((0, n)), np.zeros(0), np.zeros(0))
    levels = [Level(0, [], np.zeros((0, n)), np.zeros(0), *none, None, {}, {})]
    levels += [Level(k + 1, [], A, b, *none, None, {}, {}) for k, (A, b) in enumerate(zip(blocks, targets))]
    x = WeightedQP(level_weight=1e-3).solve_levels(levels, n).x
    w = [np.sqrt(1e-3**k) for k in range(4)]
    ref = np.linalg.lstsq(np.vstack([wk * A for wk, A in zip(w, blocks)]),
                          np.concatenate([wk * b for wk, b in zip(w, targets)]), rcond=None)[0]
    np.testing.assert_allclose(x, ref, rtol=1e-7, atol=1e-9 * np.abs(ref).max())


def test_nnls_warm_start_is_certified_only_at_the_optimum():
    """The projection solver's force distribution keeps the last support of λ only if the
    least-squares point on it passes the KKT test: on random non-negative least-squares
    problems (a few generators active, as at a foot), from scipy's own solution's support it
    is certified and equal to scipy's; from a support with one active generator dropped, or
    one inactive generator added where that is not optimal, it is refused (or, if
    certified, just as good)."""
    from scipy.optimize import nnls

    rng = np.random.default_rng(7)
    certified = refused = 0
    for _ in range(40):
        A = rng.standard_normal((18, 32)) * np.r_[np.full(6, 1e3), np.full(12, 1.0)][:, None]
        b = A @ np.maximum(rng.standard_normal(32), 0.0) + rng.standard_normal(18)
        lam, rnorm = nnls(A, b, maxiter=2000)
        ok, mine = nnls_on_support(A, b, lam, 10.0, 0.0)
        assert ok
        assert np.linalg.norm(A @ mine - b) <= rnorm + 1e-9 * np.linalg.norm(b)
        assert np.allclose(A @ mine, A @ lam, rtol=0, atol=1e-9 * np.linalg.norm(b))
        active, inactive = np.flatnonzero(lam > 0), np.flatnonzero(lam == 0)
        for j in (active[:1], inactive[:1]):
            wrong = lam.copy()
            wrong[j] = 0.0 if lam[j] > 0 else 1.0
            ok, guess = nnls_on_support(A, b, wrong, 10.0, 0.0)
            if ok:
                certified += 1
                assert np.all(guess >= 0)
                assert np.linalg.norm(A @ guess - b) <= rnorm + 1e-9 * np.linalg.norm(b)
            else:
                refused += 1
    assert refused > 40         # a wrong support is, as a rule, caught


def test_active_set_guess_is_certified_only_at_the_qp_optimum():
    """A QP's optimum from the active set the unconstrained minimiser suggests is accepted
    only with its KKT certificate: every certified point is daqp's optimum (unique, H ≻ 0),
    including with two or more rows held; a wrong guess (the optimum holds other rows, or
    fewer) is refused."""
    from wbc.solvers.backends import make_backend
    from wbc.solvers.kernels.active_set import certified_active_set

    daqp = make_backend("daqp")
    rng = np.random.default_rng(5)
    certified, refused, held = 0, 0, set()
    for trial in range(400):
        k, m = int(rng.integers(2, 10)), int(rng.integers(1, 14))
        F = rng.standard_normal((k + 2, k))
        H = F.T @ F + (1e-6 if trial % 4 == 0 else 1e-2) * np.eye(k)     # some ill-conditioned
        g = 3.0 * rng.standard_normal(k)
        C = rng.standard_normal((m, k))
        lo, hi = -rng.uniform(0.0, 2.0, m), rng.uniform(0.0, 2.0, m)   # z = 0 feasible
        lo[rng.random(m) < 0.3] = -1e20
        ref = daqp.solve(H, g, C, lo, hi)
        assert ref.ok
        ok, z = certified_active_set(H, g, C, lo, hi, 1e-9)
        if not ok:
            refused += 1
            continue
        certified += 1
        np.testing.assert_allclose(z, ref.z, rtol=0, atol=1e-6 * (1 + np.abs(ref.z).max()))
        y = C @ z
        held.add(int(np.sum((np.abs(y - hi) < 1e-9) | (np.abs(y - lo) < 1e-9))))
    print(f"\n{certified} certified ({sorted(held)} rows held), {refused} refused")
    assert certified > 80 and refused > 50 and max(held) >= 2
    # nothing is certified from non-finite data or an H that is not positive definite
    eye, g, lo, hi = np.eye(2), np.array([3.0, 1.0]), -np.ones(2), np.ones(2)
    assert certified_active_set(eye, g, eye, lo, hi, 1e-9)[0]
    assert not certified_active_set(eye, np.array([np.nan, 1.0]), eye, lo, hi, 1e-9)[0]
    assert not certified_active_set(eye, g, np.array([[np.nan, 1.0], [0.0, 1.0]]), lo, hi, 1e-9)[0]
    assert not certified_active_set(np.array([[1.0, 2.0], [2.0, 1.0]]), g, eye, lo, hi, 1e-9)[0]


def test_compiled_saturation_in_the_null_space_equals_the_python_loop():
    """The projection solver's compiled levels (``projection_prefix``) take the steps of
    its Python SNS loop (``tests/helpers/reference_projection.py``): the same saturated joints in the same order, the
    same task scaling, ranks, point, step count and route hints, on random levels and
    joint-acceleration boxes."""
    from types import SimpleNamespace

    from wbc.problem.result import LevelInfo
    from wbc.solvers.cascade import GRAM_MIN_RATIO, NO_DAMPING, adopt_run
    from wbc.solvers.projection import RecursiveProjection

    solver = RecursiveProjection()
    d = solver.damping
    rng = np.random.default_rng(7)
    saturations = scaled = kept_rows = tie_splits = 0
    for trial in range(1000):
        # one-row levels (half the trials) make refused saturations, hence scaling, common
        nv, L = int(rng.integers(5, 10)), int(rng.integers(2, 5))
        ms = rng.integers(1, 2 if trial % 2 else 4, L)
        A = rng.standard_normal((int(ms.sum()), nv))
        b = 3.0 * rng.standard_normal(int(ms.sum()))
        ends = np.cumsum(ms)
        rows = np.stack([ends - ms, ends], axis=1).astype(np.int64)
        idx = np.arange(nv, dtype=np.int64)
        lo = rng.uniform(-1.0, 0.0, nv)
        hi = lo + rng.uniform(0.5, 2.0, nv)
        x0 = np.clip(np.zeros(nv), lo, hi)
        tols = np.array([[d.rank_tol, d.threshold, d.max_damping]] * L).T.copy()
        hints_c, hints_p = hint_table(), hint_table()
        # general rows kept by scaling below level 0 (the torque limits) in a third of the trials,
        # feasible at x0 (inside by a random slack), else none
        ng = int(rng.integers(1, 4)) if trial % 3 == 0 else 0
        gC = rng.standard_normal((ng, nv))
        g_mid = gC @ x0
        g = (gC, g_mid - rng.uniform(0.2, 2.0, ng), g_mid + rng.uniform(0.2, 2.0, ng))
        out = projection_prefix((A, b, rows, nv), x0, (idx, lo, hi), (np.zeros((0, 0)), False), hints_c,
                                (tols[0], tols[1], tols[2], GRAM_MIN_RATIO, solver.box_tol, NO_DAMPING.rank_tol), g)
        fast, cas_c = [], Cascade(nv, hints_c)
        levels = [SimpleNamespace(index=k) for k in range(L)]
        assert adopt_run(levels, cas_c, fast, 0, out)[0] == L
        cas = Cascade(nv, hints_p)
        cas.x = x0.copy()
        for k in range(L):
            info = LevelInfo(k, dof_before=cas.dof)
            r0, r1 = rows[k]
            gx = gC @ cas.x
            # a general row on its bound to rounding (where a previous level's scaling left x): whether
            # this level's step is scaled to 0 or to a ~1e-16/1e-14 ratio is decided by rounding, which
            # differs with the CPU's BLAS kernels (numpy's 2-term dot takes an FMA on some CPUs)
            tie = bool(k and np.any(np.abs(np.minimum(gx - g[1], g[2] - gx)) <= 1e-12 * (1.0 + np.abs(gx))))
            over = np.maximum(np.maximum(g[1] - gx, gx - g[2]), 0.0)
            step = sns_level(solver, cas, A[r0:r1], b[r0:r1], (idx, lo, hi), None, info, scale=k > 0, g=g)
            if k:           # below level 0 the general rows get no worse (inside stays inside)
                after = np.maximum(np.maximum(g[1] - gC @ cas.x, gC @ cas.x - g[2]), 0.0)
                assert np.all(after <= over + 1e-9)
            info.rank = step.rank
            a = fast[k]
            if tie and a.scale != pytest.approx(info.scale, rel=1e-12, abs=1e-12):
                tie_splits += 1     # the two took either side of the tie: the rest of the trial not compared
                break
            assert (a.saturated, a.dof_before, a.rank) == (info.saturated, info.dof_before, info.rank)
            assert a.scale == pytest.approx(info.scale, rel=1e-12, abs=1e-12)
            saturations += len(info.saturated)
            scaled += info.scale < 1.0
            kept_rows += ng > 0 and info.scale < 1.0
        else:
            np.testing.assert_allclose(cas_c.x, cas.x, rtol=0, atol=1e-9 * (1 + np.abs(cas.x).max()))
            assert cas_c.calls == cas.calls
            np.testing.assert_array_equal(hints_c, hints_p)
    print(f"\n{saturations} saturations, {scaled} scaled levels ({kept_rows} by the general rows)")
    assert kept_rows > 20
    assert saturations > 1000 and scaled > 40
    assert tie_splits <= 3      # rounding-level ties split the two: rare (1 in 1000 on an AMD EPYC, 0 elsewhere)


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_compiled_cascade_prefix_equals_the_level_by_level_loop(solver):
    """The compiled prefix (every level that needs no QP, or whose step keeps the joint
    limits, in one call) gives what the per-level Python loop gives: the same x, statuses,
    QP counts and per-level diagnostics, on random states and targets (where limits and
    QPs cut the prefix short at various levels) and along the benchmark's trajectory."""
    from tests.helpers.stacks import DT, bench_stack, moving_targets

    rng = np.random.default_rng(11)
    robot_a, robot_b = wbc.load_robot("talos"), wbc.load_robot("talos")
    seen = set()
    for stack_a, stack_b, moving in ((talos_stack(), talos_stack(), False), (bench_stack(), bench_stack(), True)):
        fast = wbc.Controller(robot_a, stack_a, solver=solver)
        plain = wbc.Controller(robot_b, stack_b, solver=solver)
        if solver == "hqp":         # the Python loop the compiled run is checked against
            plain.solver.solve_levels = partial(reference_solve_levels, plain.solver)
        else:
            plain.solver.solve_accelerations = partial(reference_solve_accelerations, plain.solver)
        q, v = robot_a.q_default.copy(), np.zeros(robot_a.nv)
        robot_a.update(q, v)
        robot_b.update(q, v)
        if moving:
            targets_a, targets_b = moving_targets(robot_a, stack_a), moving_targets(robot_b, stack_b)
        stops, qps = set(), 0
        for k in range(400 if moving else 60):
            if moving:
                targets_a(k * DT)
                targets_b(k * DT)
            else:
                q, v = same_random_case(rng, (robot_a, stack_a), (robot_b, stack_b))
            # each cycle a function of its state alone (both at the fast one's state: a
            # rounding-level difference, which BLAS may make depending on memory alignment,
            # is not fed back)
            a, b = fast.solve(q, v), plain.solve(q, v)
            np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-8 * (1 + np.abs(b.x).max()))
            assert (a.status, a.qp_count) == (b.status, b.qp_count)
            for da, db in zip(a.diagnostics, b.diagnostics):
                assert (da.rank, da.dof_before, da.used_qp, da.saturated_joints) == \
                    (db.rank, db.dof_before, db.used_qp, db.saturated_joints)
                assert da.sigma_min == pytest.approx(db.sigma_min, rel=1e-9, abs=1e-12)
            stops.add(next((i for i, d in enumerate(a.diagnostics) if d.used_qp or d.saturated_joints), "end"))
            qps += a.qp_count
            if moving:
                v = v + a.qdd * DT
                q = pin.integrate(robot_a.model, q, v * DT)
        print(f"\n{solver} ({'trajectory' if moving else 'random states'}): first level with a QP or a "
              f"saturation {sorted(stops, key=str)}, {qps} QPs")
        seen |= stops
    # the prefix was cut short at several levels (the projection's only stop is a joint
    # limit: it has no QP), and ran through
    assert len(seen - {"end"}) >= (3 if solver == "hqp" else 1) and "end" in seen


def test_unit_rows_are_read_off_the_basis_bit_for_bit():
    """projected_rows reads unit rows (a posture's, a wrench target's) off Z and x̂: the same
    numbers as the products, to the last bit; any other row takes the products."""
    from wbc.solvers.kernels.factorizations import projected_rows, unit_columns

    rng = np.random.default_rng(3)
    n, k = 12, 7
    Z = np.linalg.qr(rng.standard_normal((n, k)))[0]
    x, b = rng.standard_normal(n), rng.standard_normal(5)
    A = np.zeros((5, n))
    A[np.arange(5), [3, 0, 11, 3, 7]] = 1.0
    assert unit_columns(A).tolist() == [3, 0, 11, 3, 7]
    for identity in (False, True):
        AZ, r = projected_rows(A, b, x, Z, identity)
        assert np.array_equal(AZ, A if identity else A @ Z) and np.array_equal(r, b - A @ x)
    for bad in ((0, 1, 2.0), (1, 4, 1e-3), (4, 7, 0.0)):      # a 2, a second entry, a zero row
        B = A.copy()
        B[bad[0], bad[1]] = bad[2]
        assert len(unit_columns(B)) == 0
        AZ, r = projected_rows(B, b, x, Z, False)
        np.testing.assert_allclose(AZ, B @ Z, rtol=0, atol=1e-15)
        np.testing.assert_allclose(r, b - B @ x, rtol=0, atol=1e-15)


def test_a_full_posture_level_takes_its_step_without_the_gram_matrix():
    """Unit rows on every coordinate once (a fixed-base robot's posture over all of q̈) make
    A Z orthonormal: the step is (AZ)ᵀ r with σ = 1, equal to the Cholesky route's (which
    forms and factors G) to rounding; repeated or missing coordinates take the usual route."""
    from wbc.solvers.kernels.factorizations import GRAM, level_step, projected_rows_full, step_from

    rng = np.random.default_rng(5)
    n = 40
    for k in (40, 31, 9):
        Z = np.ascontiguousarray(np.linalg.qr(rng.standard_normal((n, k)))[0])
        x, b = rng.standard_normal(n), rng.standard_normal(n)
        A = np.eye(n)[rng.permutation(n)]
        AZ, r, full = projected_rows_full(A, b, x, Z, False)
        assert full
        fast = step_from(AZ, r, x, Z, False, GRAM, True, 1e-9, 1e-3, 1e-2, 1e-8, True)
        slow = step_from(AZ, r, x, Z, False, GRAM, True, 1e-9, 1e-3, 1e-2, 1e-8, False)
        assert fast[0] and slow[0] and fast[1] == slow[1] == GRAM and fast[2] == slow[2] == k
        assert fast[3] == fast[4] == 1.0
        np.testing.assert_allclose(fast[6][:k + n], slow[6][:k + n], rtol=0, atol=1e-12)
        # the least-squares optimum: the residual is orthogonal to the columns of A Z
        z = fast[6][:k]
        np.testing.assert_allclose(AZ.T @ (AZ @ z - r), 0.0, atol=1e-12)
        got = level_step(A, b, x, Z, False, GRAM, True, 1e-9, 1e-3, 1e-2, 1e-8)
        np.testing.assert_array_equal(got[6], fast[6])
    A = np.eye(n)[rng.permutation(n)]
    A[3] = A[4]                                    # a coordinate twice, one missing
    assert not projected_rows_full(A, b, x, Z, False)[2]
    assert not projected_rows_full(A[:-1], b[:-1], x, Z, False)[2]
