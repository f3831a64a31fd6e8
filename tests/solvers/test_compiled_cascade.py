"""The hierarchical QP's compiled run takes every level, also those that are not the row
buffer's own (the weighted QP's folded level, the levels of a force scale), single levels
and the levels below a relaxed one: it gives what the Python reference loop
(:mod:`tests.helpers.reference_hqp`) gives on random states and targets."""

from __future__ import annotations

import numpy as np
import pytest

import wbc
from tests.helpers.reference_hqp import reference_solve_levels
from tests.helpers.stacks import same_random_case, talos_stack
from wbc.solvers.hqp import HierarchicalQP


class _Reference:
    """Replaces HierarchicalQP.solve_levels on one solver object by the reference loop (the
    weighted QP calls it through super())."""

    def __init__(self, solver) -> None:
        self.solver = solver

    def __enter__(self):
        self.real = HierarchicalQP.solve_levels
        solver, real = self.solver, self.real

        def patched(obj, *args, **kwargs):
            if obj is solver:
                return reference_solve_levels(obj, *args, **kwargs)
            return real(obj, *args, **kwargs)

        HierarchicalQP.solve_levels = patched
        return self

    def __exit__(self, *exc):
        HierarchicalQP.solve_levels = self.real


@pytest.mark.parametrize("solver, force_scale", [("weighted", 1.0), ("hqp", 100.0), ("weighted", 100.0)])
def test_compiled_run_equals_the_reference_loop(solver, force_scale):
    rng = np.random.default_rng(5)
    robot_a, robot_b = wbc.load_robot("talos"), wbc.load_robot("talos")
    stack_a, stack_b = talos_stack(), talos_stack()
    fast = wbc.Controller(robot_a, stack_a, solver=solver)
    plain = wbc.Controller(robot_b, stack_b, solver=solver)
    fast.force_scale = plain.force_scale = force_scale
    qps = relaxed = 0
    for _ in range(60):
        q, v = same_random_case(rng, (robot_a, stack_a), (robot_b, stack_b))
        a = fast.solve(q, v)
        with _Reference(plain.solver):
            b = plain.solve(q, v)
        np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-8 * (1 + np.abs(b.x).max()))
        assert (a.status, a.qp_count) == (b.status, b.qp_count)
        for da, db in zip(a.diagnostics, b.diagnostics):
            assert (da.rank, da.dof_before, da.used_qp, da.relaxed) == (db.rank, db.dof_before, db.used_qp, db.relaxed)
        qps += a.qp_count
        relaxed += a.status == "relaxed"
    print(f"\n{solver} (force scale {force_scale}): {qps} QPs, {relaxed} cycles with a relaxed level")
    assert qps > 0


def _random_levels(rng, nx: int, n_levels: int) -> list:
    """Random levels, some with inequalities that no point meets (two rows of opposite
    ranges: the level is relaxed) or that the least-squares point violates."""
    from wbc.problem.rows import Level

    levels = []
    for k in range(n_levels):
        m = int(rng.integers(0, 4))
        A, b = rng.standard_normal((m, nx)), rng.standard_normal(m)
        mi = int(rng.integers(0, 4))
        C = rng.standard_normal((mi, nx))
        lo = rng.uniform(-1.0, 0.0, mi)
        hi = lo + rng.uniform(0.0, 1.0, mi)
        if mi and rng.random() < 0.4:   # the same row twice, with ranges that do not meet
            C = np.vstack([C, C[:1]])
            lo, hi = np.append(lo, hi[0] + 0.5), np.append(hi, hi[0] + 1.0)
        levels.append(Level(k, [], A, b, C, lo, hi, None, {}, {}))
    return levels


@pytest.mark.parametrize("certify", [True, False])
def test_compiled_run_on_relaxed_and_single_levels(certify):
    """Levels below a relaxed one (the run reads their bounds relaxed), single levels and
    levels of no row buffer, with and without the certificates: as the reference loop."""
    rng = np.random.default_rng(3)
    relaxed = stops = 0
    for trial in range(300):
        nx = int(rng.integers(2, 7))
        levels = _random_levels(rng, nx, int(rng.integers(1, 5)))
        x_ref = rng.standard_normal(nx) if trial % 2 else None
        a = HierarchicalQP(certify=certify).solve_levels(levels, nx, x_ref=x_ref)
        b = reference_solve_levels(HierarchicalQP(certify=certify), levels, nx, x_ref=x_ref)
        np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-8 * (1 + np.abs(b.x).max()))
        assert (a.ok, a.qp_count, a.message) == (b.ok, b.qp_count, b.message)
        for da, db in zip(a.levels, b.levels, strict=True):
            assert (da.rank, da.dof_before, da.used_qp, da.relaxed, da.qp_status) == \
                (db.rank, db.dof_before, db.used_qp, db.relaxed, db.qp_status)
        relaxed += any(d.relaxed for d in a.levels[:-1])
        stops += any(d.used_qp for d in a.levels)
    print(f"\n{relaxed} problems with a relaxed level above another, {stops} with a QP")
    assert relaxed > 20 and stops > 50


@pytest.mark.parametrize("weighting", ["identity", "inertia"])
def test_compiled_projection_equals_the_reference_loop(weighting):
    """The projection solver's compiled run, with the inertia weighting too (q̈ = T y, the box
    on q̈), gives what its Python SNS loop (:mod:`tests.helpers.reference_projection`) gives: the same
    q̈, saturated joints, task scalings and ranks, on random states and targets."""
    from functools import partial

    from tests.helpers.reference_projection import reference_solve_accelerations

    rng = np.random.default_rng(9)
    robot_a, robot_b = wbc.load_robot("talos"), wbc.load_robot("talos")
    stack_a, stack_b = talos_stack(), talos_stack()
    fast = wbc.Controller(robot_a, stack_a, solver="projection", weighting=weighting)
    plain = wbc.Controller(robot_b, stack_b, solver="projection", weighting=weighting)
    plain.solver.solve_accelerations = partial(reference_solve_accelerations, plain.solver)
    saturated = 0
    for _ in range(60):
        q, v = same_random_case(rng, (robot_a, stack_a), (robot_b, stack_b))
        a, b = fast.solve(q, v), plain.solve(q, v)
        np.testing.assert_allclose(a.qdd, b.qdd, rtol=0, atol=1e-8 * (1 + np.abs(b.qdd).max()))
        assert a.status == b.status
        for da, db in zip(a.diagnostics, b.diagnostics, strict=True):
            assert (da.rank, da.dof_before, da.saturated_joints) == (db.rank, db.dof_before, db.saturated_joints)
            assert da.sigma_min == pytest.approx(db.sigma_min, rel=1e-9, abs=1e-12)
            saturated += len(da.saturated_joints)
    print(f"\n{weighting}: {saturated} saturated joints")
    assert saturated > 0
