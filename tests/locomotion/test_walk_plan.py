"""A walk's plan changed at run time (a new command, a stop) and the ``walk:`` section's errors."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from wbc.errors import ConfigError
from wbc.locomotion.footsteps import Footstep, StepLimits, check_plan, from_command
from wbc.locomotion.plan import Command, WalkPlan
from wbc.locomotion.timing import Timing
from wbc.scenario.loader import load_config

START = {"left": Footstep("left", 0.0, 0.085, 0.0), "right": Footstep("right", 0.0, -0.085, 0.0)}
LIMITS = StepLimits()
TIMING = Timing()


def _plan(steps=4):
    return WalkPlan(START, from_command(START, (0.25, 0.0, 0.0), 0.8, steps, LIMITS), TIMING, 0.0, LIMITS)


def _contiguous(plan):
    for a, b in zip(plan.phases, plan.phases[1:], strict=False):
        assert b.t0 == pytest.approx(a.t1)
        assert np.allclose(b.zmp0, a.zmp1)          # the ZMP reference is continuous


def test_new_command_keeps_the_begun_steps_and_continues_their_timeline():
    plan = _plan()
    kept = plan.steps[:2]
    single = plan.single[:2]
    new = plan.replace_from(2, 1.0, Command(0.1, 0.0, 0.0, 2))
    assert plan.steps[:2] == kept and plan.single[:2] == single
    assert [s.side for s in plan.steps] == ["right", "left", "right", "left", "right"]
    assert new[0].x == pytest.approx(kept[-1].x + 0.08)     # 0.1 m/s × 0.8 s ahead of the last foot down
    check_plan(START, plan.steps, LIMITS)
    _contiguous(plan)
    assert len(plan.single) == len(plan.steps)


def test_stop_brings_the_next_foot_beside_the_last_one():
    plan = _plan(6)
    plan.replace_from(3, 2.0, None)
    assert len(plan.steps) == 4
    a, b = plan.steps[-1], plan.steps[-2]
    assert a.x == pytest.approx(b.x) and abs(a.y - b.y) == pytest.approx(0.17)
    _contiguous(plan)
    assert plan.phases[-1].kind == "double"
    assert np.allclose(plan.phases[-1].zmp1, [(a.x + b.x) / 2, 0.0])


def test_command_after_the_end_starts_again_from_the_feet_down():
    plan = _plan(2)
    end = plan.end
    plan.replace_from(len(plan.steps), end + 1.0, Command(0.2, 0.0, 0.0, 2))
    assert len(plan.steps) == 6
    assert plan.single[3][0] == pytest.approx(end + 1.0 + TIMING.first)
    check_plan(START, plan.steps, LIMITS)


def _scenario(tmp_path, walk: str, duration: float = 6.0):
    src = tmp_path / "walk.yaml"
    src.write_text(textwrap.dedent(f"""\
        robot: talos
        duration: {duration}
        stack:
          - - {{type: contact, contact: left_foot}}
            - {{type: contact, contact: right_foot}}
          - - {{type: com}}
          - - {{type: posture}}
        walk:
        """) + textwrap.indent(textwrap.dedent(walk), "  "))
    return src


@pytest.mark.parametrize(("walk", "key", "words"), [
    ("command: {v_x: 0.5, steps: 2}\n", "walk.command.v_x", "over the limit"),
    ("command: {v_x: 0.2, steps: 2}\ntiming: {double: 0.1, ramp: 0.1}\n", "walk.timing.double", "shorter"),
    ("footsteps:\n  - {side: right, x: 0.1, y: 0.02}\n", "walk.footsteps[0]", "overlap"),
    ("footsteps:\n  - {side: right, x: 0.6, y: -0.085}\n", "walk.footsteps[0]", "max_length"),
    ("command: {v_x: 0.2, steps: 20}\n", "walk", "after the run's end"),
    ("command: {v_x: 0.2}\n", "walk.command.steps", "missing"),
    ("command: {v_x: 0.2, steps: 2}\nfootsteps: []\n", "walk", "exactly one"),
    ("command: {v_x: 0.2, steps: 2}\nevents: [{time: 1.0, command: {omega: 3.0, steps: 2}}]\n",
     "walk.events[0].command.omega", "over the limit"),
])
def test_bad_walk_sections_name_file_line_and_key(tmp_path, walk, key, words):
    src = _scenario(tmp_path, walk)
    with pytest.raises(ConfigError) as err:
        load_config(src)
    msg = str(err.value)
    assert f"{src}:" in msg and key in msg and words in msg


def test_walk_section_defaults_come_from_the_robot(tmp_path):
    sc = load_config(_scenario(tmp_path, "command: {v_x: 0.2, steps: 2}\n"))
    w = sc.walk
    assert w is not None and w.command.steps == 2
    # Talos: CoM about 0.87 m above the soles, soles 0.13 m wide
    assert 0.04 < w.step_height < 0.06
    assert w.limits.min_width == pytest.approx(0.15)
    assert 0.2 < w.limits.max_length < 0.3
