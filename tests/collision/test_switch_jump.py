"""``drift: switching``: wbc.collision.drift.switch_jump (the jump of ḋ at a closest-feature switch ahead, on a
distance that is the minimum of two feature distances along one prismatic joint, d(x) = min(f₁(x), f₂(x)), x the
joint's position) and the collision task's choice per row (wbc.tasks.collision_avoidance's module docstring)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.collision.drift import curvature_drift, switch_jump
from wbc.collision.model import DistanceRows
from wbc.problem.rows import Layout
from wbc.robot.loader import load_robot
from wbc.tasks.collision_avoidance import CollisionAvoidance

EPS = 1e-2          # the model's drift step (s)


class _Robot:
    """One prismatic joint along x at (q, v)."""

    def __init__(self, q: float, v: float) -> None:
        self.model = pin.Model()
        self.model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "x")
        self.q, self.v = np.array([q]), np.array([v])


class _Model:
    """The collision model's finite-difference data, its one pair's distance ``dist(x)`` read from the joint's
    placement."""

    def __init__(self, robot: _Robot, dist) -> None:
        self.geometry_model = pin.GeometryModel()
        self.fd_geometry_data = pin.GeometryData(self.geometry_model)
        self.fd_data = robot.model.createData()
        self.drift_step, self.dist = EPS, dist
        self.switch_step: float | None = None

    def pair_distances(self, ks, gd):
        return np.array([self.dist(self.fd_data.oMi[1].translation[0]) for _ in ks])


def _jump(dist, slope, q=0.0, v=1.0):
    """(Δ̂ (m/s), a (m/s²)) of ``dist`` at x = ``q`` moving at ``v`` with ḋ = ``slope`` · v."""
    robot = _Robot(q, v)
    _, jump, a = switch_jump(_Model(robot, dist), robot, np.array([0]), np.array([slope * v]))
    return float(jump[0]), float(a[0])


def f1(x):
    """The closest features' distance before a switch (m): 20 mm, separating at 30 mm/s, curving at +2 m/s²."""
    return 0.02 + 0.03 * x + x * x


@pytest.mark.parametrize("tau", [0.0, 0.002, 0.005, 0.008])
def test_a_switch_ahead_is_the_jump_scaled_by_how_near_it_is(tau):
    # f₂ = f₁ − 0.05 (x − τ) past x = τ: ḋ drops by 50 mm/s at τ; the pieces' curvature is f₁'s (behind: clean)
    jump, a = _jump(lambda x: min(f1(x), f1(x) - 0.05 * (x - tau)), 0.03)
    assert jump == pytest.approx(-0.05 * (EPS - tau) / EPS, abs=1e-9)
    assert a == pytest.approx(2.0, rel=1e-6)


def test_no_switch_or_a_switch_passed_is_no_jump():
    jump, a = _jump(f1, 0.03)
    assert jump == 0.0 and a == pytest.approx(2.0, rel=1e-6)       # smooth
    # switched 4 ms ago: the current features are f₂'s (slope 0.03 − 0.05), already in ḋ; the curvature ahead is f₂'s
    jump, a = _jump(lambda x: min(f1(x), f1(x) - 0.05 * (x + 0.004)), 0.03 - 0.05)
    assert jump == 0.0 and a == pytest.approx(2.0, rel=1e-6)


def test_a_smooth_third_derivative_is_a_small_error():
    # d = 0.02 − x³ (x = v t, v = 0.5 m/s, d⃛ = −0.75 m/s³): a = ε |d⃛|/3 = 2.5 mm/s², Δ̂ = −ε² |d⃛|/3 = −0.025 mm/s
    jump, a = _jump(lambda x: 0.02 - x ** 3, 0.0, v=0.5)
    assert a == pytest.approx(2 * EPS * 0.5 ** 3, rel=1e-6)
    assert jump == pytest.approx(-2 * EPS ** 2 * 0.5 ** 3, rel=1e-6)


def _staircase(x):
    """f₁ between two switches, 4 ms behind and 4 ms ahead (x = v t at v = 1 m/s), ḋ dropping by 50 mm/s at each."""
    return min(f1(x) + 0.05 * (x + 0.004), f1(x), f1(x) - 0.05 * (x - 0.004))


def test_switches_on_both_sides_lower_both_long_differences_not_the_short_ones():
    # with ε alone both one-sided differences read −4 m/s² (the staircase hands3 left: switches on both sides of the
    # ±10 ms window); the ±1 ms ones see none and give f₁'' = +2, and Δ̂ is the switch ahead's jump, −0.05 (ε − τ)/ε
    robot = _Robot(0.0, 1.0)
    cm = _Model(robot, _staircase)
    _, jump, a = switch_jump(cm, robot, np.array([0]), np.array([0.03]))
    assert a[0] == pytest.approx(-4.0, rel=1e-6) and jump[0] == 0.0          # without the short step
    cm.switch_step = 1e-3
    _, jump, a = switch_jump(cm, robot, np.array([0]), np.array([0.03]))
    assert a[0] == pytest.approx(2.0, rel=1e-6)
    assert jump[0] == pytest.approx(-0.05 * (EPS - 0.004) / EPS, rel=1e-6)


def test_a_switch_at_the_point_itself_is_seen_through_by_the_second_differences_ahead():
    # a switch 0.1 µs ahead (ḋ still the old features' slope: a₊(s) ≈ −2 · 0.05/s) and one 0.2 ms behind (a₋(s), c₋
    # lowered): the one-sided differences all read far below f₁'' = 2, c₊ (centred at +s, the new features) reads it
    robot = _Robot(0.0, 1.0)
    cm = _Model(robot, lambda x: min(f1(x) + 0.05 * (x + 2e-4), f1(x), f1(x) - 0.05 * (x - 1e-7)))
    cm.switch_step = 2.5e-4
    _, jump, a = switch_jump(cm, robot, np.array([0]), np.array([0.03]))
    assert 2.0 - 0.1 <= a[0] <= 2.0 + 1e-6
    assert jump[0] == pytest.approx(-0.05, rel=0.01)            # the switch ahead, whole: Δ (ε − τ)/ε
    cm.switch_step = None
    _, _, a = switch_jump(cm, robot, np.array([0]), np.array([0.03]))
    assert a[0] < -4.0


@pytest.mark.parametrize("tau", [-0.0005, 0.0, 0.0005, 0.003])
def test_the_short_differences_never_exceed_the_current_features_curvature(tau):
    # a switch anywhere near (even within the short step): a is at most f₁'' (d ≤ f₁, equal at x = 0), never above
    robot = _Robot(0.0, 1.0)
    slope = 0.03 - (0.05 if tau < 0 else 0.0)        # a switch passed is in ḋ: the current features are f₂
    cm = _Model(robot, lambda x: min(f1(x), f1(x) - 0.05 * (x - tau)))
    cm.switch_step = 2.5e-4
    _, _, a = switch_jump(cm, robot, np.array([0]), np.array([slope]))
    assert a[0] <= 2.0 + 1e-6


def test_its_drift_is_the_exact_drift_bit_for_bit():
    d = lambda x: min(f1(x), f1(x) - 0.05 * (x - 0.003))    # noqa: E731
    robot = _Robot(0.1, 0.7)
    cm = _Model(robot, d)
    central, _, _ = switch_jump(cm, robot, np.array([0]), np.array([0.03 + 2 * 2.0 * 0.1]))
    assert central[0] == curvature_drift(cm, robot, np.array([0]))[0]


def _task_rows(d, d_dot, exact, jump, local):
    """The collision task's rows (lo, m/s²) of ``drift: switching`` on the given distance rows (one pair each)."""
    robot = load_robot("panda")
    task = CollisionAvoidance(influence=0.05, safety=0.005, max_speed=0.5, self_collision=False,
                              obstacles=[{"type": "sphere", "center": [2.0, 0.0, 0.0], "radius": 0.1}],
                              drift="switching", max_rows=len(d))
    task.bind(robot)
    k, nv = len(d), robot.nv
    rows = DistanceRows(np.zeros(k, dtype=np.int64), np.array(d), np.array(d_dot), np.ones((k, nv)), np.array(exact),
                        np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3)), np.array(jump), np.array(local))
    task.model.distance_rows = lambda robot, influence: rows
    out = task.rows(robot, Layout(nv=nv))
    return task, out.lo


def test_a_switch_that_leaves_the_pair_in_its_safe_set_is_a_jump_of_its_velocity():
    # a pair 10 mm above d_s separating at 30 mm/s, a switch ahead dropping ḋ by 50 mm/s: after it h = −0.02 + ω e =
    # 0.091 m/s ≥ 0, so the row is the damper at ḋ + Δ̂ with the local model's drift (+1.5), not the exact drift (−5.5)
    task, lo = _task_rows([0.015], [0.03], [-5.5], [-0.05], [1.5])
    w, e = task.omega, 0.01
    assert lo[0] == pytest.approx(-2 * w * (0.03 - 0.05) - w * w * e - 1.5, abs=1e-12)
    assert lo[0] < -2 * w * 0.03 - w * w * e + 5.5 - 3.0     # far below the exact drift's demand


def test_a_switch_that_would_take_the_pair_out_of_its_safe_set_keeps_the_exact_drift():
    # at d_s + 1 mm approaching at 5 mm/s, the same switch: ḋ + Δ̂ + ω e < 0: braked as the exact drift asks
    task, lo = _task_rows([0.006], [-0.005], [-5.5], [-0.05], [1.5])
    w = task.omega
    assert lo[0] == pytest.approx(-2 * w * (-0.005) - w * w * 0.001 + 5.5, abs=1e-12)
