"""The locomotion planning (issue #24): footstep limits, the swing spline's boundary
conditions, and the preview-controlled LIPM whose ZMP stays in the stance foot's sole."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.errors import ConfigError
from wbc.locomotion.footsteps import Footstep, StepLimits, check_plan, from_command, relative
from wbc.locomotion.preview import STANDARD_GRAVITY, ZmpPreview
from wbc.locomotion.swing import SwingTrajectory
from wbc.locomotion.timing import Timing, ZmpTable, schedule, zmp_reference, zmp_samples

START = {"left": Footstep("left", 0.0, 0.085, 0.0), "right": Footstep("right", 0.0, -0.085, 0.0)}
LIMITS = StepLimits(max_length=0.25, min_width=0.12, max_width=0.35, max_turn=0.35)
HALF_LENGTH, HALF_WIDTH = 0.10, 0.05          # a Talos sole, m


# ------------------------------------------------------------------ footsteps
def test_command_forward_plan_ends_side_by_side_and_keeps_the_limits():
    steps = from_command(START, (0.25, 0.0, 0.0), 0.8, 10, LIMITS)
    assert len(steps) == 11
    check_plan(START, steps, LIMITS)
    assert [s.side for s in steps[:3]] == ["right", "left", "right"]
    last, other = steps[-1], steps[-2]
    assert last.x == pytest.approx(other.x) and abs(last.y - other.y) == pytest.approx(0.17)
    assert (last.x + other.x) / 2 == pytest.approx(10 * 0.2)
    # each foot lands 0.2 m ahead of the stance foot in the steady steps
    assert relative(steps[4], steps[3])[0] == pytest.approx(0.2)


def test_command_lateral_and_turning_plans_keep_the_limits():
    side = from_command(START, (0.0, 0.05 / 0.8, 0.0), 0.8, 6, LIMITS)   # 0.1 m lateral steps
    check_plan(START, side, LIMITS)
    assert side[0].side == "left"
    assert (side[-1].y + side[-2].y) / 2 == pytest.approx(3 * 0.1, abs=1e-9)
    turn = from_command(START, (0.1, 0.0, (math.pi / 2) / (10 * 0.8)), 0.8, 10, LIMITS)
    check_plan(START, turn, LIMITS)
    assert turn[-1].yaw == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(("command", "key"), [((0.4, 0.0, 0.0), "walk.command.v_x"),
                                              ((0.0, 0.2, 0.0), "walk.command.v_y"),
                                              ((0.0, 0.0, 0.6), "walk.command.omega"),
                                              # both beyond: a turn moves the foot along the stance
                                              # foot by half a width × sin(turn) on top of v_x's
                                              ((1.0, 0.0, 0.2), "walk.command.v_x")])
def test_command_beyond_the_limits_is_refused_or_clipped(command, key):
    with pytest.raises(ConfigError) as err:
        from_command(START, command, 0.8, 4, LIMITS)
    assert key in str(err.value)
    clipped = from_command(START, command, 0.8, 4, LIMITS, clip=True)
    check_plan(START, clipped, LIMITS)


@pytest.mark.parametrize(("step", "words"), [(Footstep("right", 0.1, 0.02, 0.0), "min_width"),
                                             (Footstep("right", 0.1, -0.5, 0.0), "max_width"),
                                             (Footstep("right", 0.4, -0.085, 0.0), "max_length"),
                                             (Footstep("right", 0.1, -0.085, 0.5), "max_turn"),
                                             (Footstep("left", 0.1, 0.085, 0.0), "twice")])
def test_check_plan_names_the_step_and_the_limit(step, words):
    steps = [Footstep("left", 0.1, 0.085, 0.0), step]
    with pytest.raises(ConfigError, match=words) as err:
        check_plan(START, steps, LIMITS)
    assert "walk.footsteps[1]" in str(err.value)


def test_timing_refuses_a_double_support_shorter_than_its_ramps():
    with pytest.raises(ConfigError, match="double"):
        Timing(double=0.15, ramp=0.1).check()
    Timing(double=0.2, ramp=0.1).check()


# ------------------------------------------------------------------ swing
def test_swing_spline_boundary_conditions_and_apex():
    p0, p1 = [0.0, -0.085, 0.0, 0.0], [0.4, -0.085, 0.0, 0.3]
    sw = SwingTrajectory(p0, p1, 0.6, 0.05)
    for t, p in ((0.0, p0), (0.6, p1)):
        x, v, a = sw.sample(t)
        assert np.allclose(x, p, atol=1e-12) and np.allclose(v, 0, atol=1e-12) and np.allclose(a, 0, atol=1e-9)
    x, v, a = sw.sample(0.3)
    assert x[2] == pytest.approx(0.05) and v[2] == pytest.approx(0.0, abs=1e-12)
    assert x[0] == pytest.approx(0.2)
    # velocity and acceleration are the derivatives (finite differences), across the apex too
    h = 1e-6
    for t in (0.1, 0.3 - 1e-3, 0.3 + 1e-3, 0.5):
        xp, vp, _ = sw.sample(t + h)
        xm, vm, _ = sw.sample(t - h)
        x, v, a = sw.sample(t)
        assert np.allclose((xp - xm) / (2 * h), v, atol=1e-5)
        assert np.allclose((vp - vm) / (2 * h), a, atol=1e-3)
    assert max(sw.sample(t)[0][2] for t in np.linspace(0, 0.6, 61)) == pytest.approx(0.05)


# ------------------------------------------------------------------ preview control
def _lipm_walk(push_at: float | None = None, push_dv: float = 0.0, g: float = STANDARD_GRAVITY):
    """The exact LIPM (cart-table at 1 kHz, gravity ``g``) driven by the preview plan, replanned
    every 10 ms from its own (the "measured") state: the ZMP of the pendulum and the stance feet."""
    z_c, dt = 0.87, 0.001
    timing = Timing(single=0.6, double=0.2, first=0.6, last=0.8, ramp=0.1)
    steps = from_command(START, (0.25, 0.0, 0.0), 0.8, 10, LIMITS)
    phases = schedule(START, steps, timing)
    plan = ZmpPreview(z_c, ZmpTable(phases).sample, g=g)
    c, dc = np.zeros(2), np.zeros(2)
    plan.reset(c, dc, 0.0)
    n = round(phases[-1].t1 / dt) + 500
    out = []
    for k in range(n):
        t = k * dt
        if push_at is not None and abs(t - push_at) < dt / 2:
            dc = dc + np.array([0.0, push_dv])
        if plan.due(t):
            plan.replan(c, dc, t)
        _, _, acc = plan.sample(t)
        zmp = c - z_c * acc / g
        out.append((t, zmp.copy(), zmp_reference(phases, t)))
        c, dc = c + dc * dt + acc * dt * dt / 2, dc + acc * dt
    return phases, steps, out, c, plan


def test_zmp_table_samples_as_the_reference():
    steps = from_command(START, (0.25, 0.0, 0.0), 0.8, 4, LIMITS)
    phases = schedule(START, steps, Timing())
    a, b = np.zeros((700, 2)), np.zeros((700, 2))
    for t in (0.0, 0.55, 1.33, 4.0, 6.0):
        assert np.allclose(ZmpTable(phases).sample(t, 0.01, 700, a), zmp_samples(phases, t, 0.01, 700, b), atol=1e-12)
    assert np.allclose(b[-1], (steps[-1].xy + steps[-2].xy) / 2)


def _inside_stance(phases, steps, out, margin=0.0):
    feet = dict(START)
    worst = np.inf
    for ph in phases:
        if ph.kind == "single":
            s = steps[ph.step]
            stance = feet["right" if s.side == "left" else "left"]
            for t, zmp, _ in out:
                if ph.t0 <= t < ph.t1:
                    d = np.abs(zmp - stance.xy)
                    worst = min(worst, HALF_LENGTH - d[0], HALF_WIDTH - d[1])
            feet[s.side] = s
    return worst


def test_preview_zmp_tracks_the_footstep_reference_inside_the_sole():
    phases, steps, out, c, plan = _lipm_walk()
    # in single support the ZMP follows the footstep's (the double supports move it ahead of the
    # reference, as a preview controller must to start the CoM moving)
    single = [ph for ph in phases if ph.kind == "single"]
    err = max(float(np.linalg.norm(z - r)) for t, z, r in out if any(ph.t0 <= t < ph.t1 for ph in single))
    assert err < 0.025                                 # m, half the sole's half-width
    assert _inside_stance(phases, steps, out) > 0.02   # 2 cm inside the stance sole in single support
    end = (steps[-1].xy + steps[-2].xy) / 2
    assert np.linalg.norm(c - end) < 0.005             # the CoM comes to rest between the feet
    assert len(plan.replan_times) >= len(out) // 10


def test_the_plan_takes_the_gravity_it_is_given():
    """The preview under another gravity (the walker passes its robot model's): the ZMP still
    follows the footsteps in single support and the CoM comes to rest between the feet."""
    phases, steps, out, c, plan = _lipm_walk(g=6.0)
    assert plan.omega == pytest.approx(np.sqrt(6.0 / 0.87))
    single = [ph for ph in phases if ph.kind == "single"]
    err = max(float(np.linalg.norm(z - r)) for t, z, r in out if any(ph.t0 <= t < ph.t1 for ph in single))
    assert err < 0.025                                 # m (0.021 here; 0.011 at 9.81)
    assert _inside_stance(phases, steps, out) > 0.02
    end = (steps[-1].xy + steps[-2].xy) / 2
    assert np.linalg.norm(c - end) < 0.005


def test_replanning_from_the_measured_state_recovers_a_push():
    """A sideways velocity kick of 0.05 m/s mid single support: the plan, replanned from the
    measured state, brings the ZMP back and keeps it in the sole (an open-loop plan would not
    see the kick and the pendulum would fall away)."""
    phases, steps, out, c, _ = _lipm_walk(push_at=3.2, push_dv=0.05)
    assert _inside_stance(phases, steps, out) > 0.0
    end = (steps[-1].xy + steps[-2].xy) / 2
    assert np.linalg.norm(c - end) < 0.01
