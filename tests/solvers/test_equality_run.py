"""The equality-only cascade (wbc.solvers.kernels.equality_run) is the hierarchical QP's solution:
on random strict hierarchies (wide levels, then a tall one of unit or general rows, inequality
rows on the levels whose bounds are loose or bind), it accepts exactly the problems the full
compiled run solves without a QP, and there gives the full run's x (to rounding), ranks,
free directions and singular values; where an inequality is met on the way it refuses and
HierarchicalQP.solve_planned's result is the full run's (the fallback)."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.problem.problem import Problem
from wbc.problem.rows import Layout, Level
from wbc.solvers.hqp import HierarchicalQP


def _random_problem(rng, n: int) -> Problem:
    """Level 0: a few equality rows and a bound |x_i| ≤ β_i on every coordinate (β from 0.02,
    which binds, to 100, which does not); two wide levels; a tall last level over the free
    directions, of distinct unit rows (a posture over all but a few coordinates) or of general
    rows; its last level's inequality rows as loose or as tight as level 0's."""
    m0, m1, m2 = int(rng.integers(1, 4)), int(rng.integers(1, 3)), int(rng.integers(1, 3))
    beta = 10.0 ** rng.uniform(-1.7, 2.0)
    C0 = np.eye(n)
    levels = [Level(0, [], rng.standard_normal((m0, n)), rng.standard_normal(m0), C0, -beta * np.ones(n),
                    beta * np.ones(n), None, {}, {})]
    for k, m in ((1, m1), (2, m2)):
        levels.append(Level(k, [], rng.standard_normal((m, n)), rng.standard_normal(m), np.zeros((0, n)),
                            np.zeros(0), np.zeros(0), None, {}, {}))
    if rng.random() < 0.5:
        cols = rng.permutation(n)[:n - int(rng.integers(0, 3))]
        A3 = np.eye(n)[cols]
    else:
        A3 = rng.standard_normal((n - m0 - m1 - m2 + int(rng.integers(0, 3)), n))
    C3 = rng.standard_normal((2, n))
    width = 10.0 ** rng.uniform(-1.0, 2.5)
    levels.append(Level(3, [], A3, rng.standard_normal(len(A3)), C3, -width * np.ones(2), width * np.ones(2), None,
                        {}, {}))
    return Problem(levels, Layout(nv=n), np.eye(n), np.zeros(n), np.zeros(0, dtype=np.int64), margin=1e-3)


class _Spy:
    """Records what the equality-only cascade answered in HierarchicalQP.solve_planned."""

    def __init__(self, monkeypatch) -> None:
        import wbc.solvers.hqp_planned as planned

        self.answers: list[bool] = []
        real = planned.equality_cascade

        def spied(*args):
            out = real(*args)
            self.answers.append(bool(out[0]))
            return out

        monkeypatch.setattr(planned, "equality_cascade", spied)


@pytest.mark.parametrize("seed", [0, 1])
def test_equality_cascade_is_the_hqp(seed, monkeypatch):
    spy = _Spy(monkeypatch)
    taken = fallback = 0
    for case in range(150):
        rng = np.random.default_rng([seed, case])
        n = int(rng.integers(8, 14))
        # a problem each: a relaxed level's bounds are relaxed in its stacked rows
        p_full, p_fast = (_random_problem(np.random.default_rng([seed, case, 1]), n) for _ in range(2))
        full, fast = HierarchicalQP(margin=1e-3), HierarchicalQP(margin=1e-3)
        full.equality_first = False
        a = full.solve_planned(p_full)
        b = fast.solve_planned(p_fast, equalities_first=True)
        ok = spy.answers[-1]
        # the full run needs a QP exactly where an inequality is met on the way (random rows: full rank)
        assert ok == (a.qp_count == 0 and a.ok), (case, ok, a.qp_count, a.message)
        if ok:
            taken += 1
            np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-10 * (1.0 + np.abs(a.x).max()))
            assert b.qp_count == 0
            for la, lb in zip(a.levels, b.levels):
                assert (la.index, la.rank, la.dof_before) == (lb.index, lb.rank, lb.dof_before)
                if la.rank:
                    np.testing.assert_allclose(lb.sigma(), la.sigma(), rtol=1e-9)
        else:
            fallback += 1           # the full run on both sides (its back-end QPs agree to their tolerance)
            np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-6 * (1.0 + np.abs(a.x).max()))
            assert b.qp_count == a.qp_count
    assert taken >= 20 and fallback >= 20, (taken, fallback)


def test_talos_ik_takes_the_equality_path_and_falls_back_where_a_limit_binds(talos, monkeypatch):
    from tests.solvers.test_solve_planned import _problem

    spy = _Spy(monkeypatch)
    for offset, expect in (((0.10, -0.05, 0.10), True),    # no joint limit met: the equality path
                           ((0.0, 0.0, 0.6), False)):      # a limit binds: the full run
        full, fast = HierarchicalQP(margin=1e-3), HierarchicalQP(margin=1e-3)
        full.equality_first = False
        a = full.solve_planned(_problem(talos, np.array(offset)))
        b = fast.solve_planned(_problem(talos, np.array(offset)), equalities_first=True)
        assert spy.answers[-1] == expect
        np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-12 * np.abs(a.x).max())
        assert [(la.rank, la.dof_before) for la in a.levels] == [(lb.rank, lb.dof_before) for lb in b.levels]


def test_a_bound_met_between_levels_is_the_full_runs(monkeypatch):
    """Level 1's least-norm step (x₀ = x₁ = 1) crosses level 0's bound x₀ ≤ 0.8 and level 2's
    brings x₀ back to 0: the final point meets every row, but the hqp solved a QP on the way
    (its records say so, and its regularisation moves x by 6e-7 from the equalities' point), so the
    equality-only cascade refuses and the full run answers."""
    spy = _Spy(monkeypatch)
    n = 3

    def level(k, A, b, C=None, lo=None, hi=None):
        C = np.zeros((0, n)) if C is None else np.array(C, dtype=float)
        lo, hi = (np.zeros(0), np.zeros(0)) if lo is None else (np.array(lo, float), np.array(hi, float))
        return Level(k, [], np.array(A, dtype=float).reshape(-1, n), np.array(b, dtype=float), C, lo, hi, None, {}, {})

    def problem():
        levels = [level(0, [], [], [[1.0, 0.0, 0.0]], [-10.0], [0.8]), level(1, [1.0, 1.0, 0.0], [2.0]),
                  level(2, [1.0, -1.0, 0.0], [-2.0]), level(3, [0.0, 0.0, 1.0], [0.5])]
        return Problem(levels, Layout(nv=n), np.eye(n), np.zeros(n), np.zeros(0, dtype=np.int64), margin=1e-3)

    full, fast = HierarchicalQP(margin=1e-3), HierarchicalQP(margin=1e-3)
    full.equality_first = False
    a, b = full.solve_planned(problem()), fast.solve_planned(problem(), equalities_first=True)
    assert spy.answers == [False]
    assert a.qp_count > 0 and b.qp_count == a.qp_count
    np.testing.assert_allclose(b.x, [0.0, 2.0, 0.5], atol=1e-5)    # the QP's regularisation: 6e-7 off
    np.testing.assert_allclose(b.x, a.x, atol=1e-12)
