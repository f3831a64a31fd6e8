"""Every task's error names the unit of each of its components (Task.error_units), and the run's
metrics report each task in its own unit: a pose task's position (m) and orientation (rad) apart.

The units come from the task's definition (a frame's mask, a posture's joint types, a force's
directions), so a wrong one (a TIAGo posture calling its prismatic torso lift "rad", a pose
calling its orientation "m") fails here.
"""

from __future__ import annotations

import math

import pytest
import yaml

from tests.tasks.test_task_jacobians import CASES, robots, setup  # noqa: F401 (robots: the fixture)
from wbc.runner.loop import run
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config
from wbc.tasks import Frame, Posture

#: (a manipulability w = √det(J Jᵀ) over p position rows is in m^p: the product of p singular values in m)
UNITS = {"m", "rad", "N", "N·m", "N|N·m", "rad|m", "unitless", "m^1", "m^2", "m^3"}


@pytest.mark.parametrize("name", ["talos", "g1", "tiago"])
@pytest.mark.parametrize("key", list(CASES))
def test_one_unit_per_error_component(robots, key, name):  # noqa: F811
    robot, task, layout, q, v, _ = setup(robots, name, key, 0)
    task.rows(robot, layout)                  # tasks that keep state for their error (null space)
    e = task.error(robot)
    units = task.error_units(robot)
    if e is None:
        assert units == ()
        return
    assert len(units) == len(e), f"{key}: {len(units)} units for an error of {len(e)} components"
    assert set(units) <= UNITS, units


def test_units_follow_the_definition(robots):  # noqa: F811
    talos, tiago = robots["talos"], robots["tiago"]
    assert Frame("left_hand").error_units(talos) == ("m",) * 3 + ("rad",) * 3
    assert Frame("left_hand", mask=[0, 1, 0, 0, 0, 1]).error_units(talos) == ("m", "rad")
    lift = "torso_lift_joint"
    units = Posture(joints=[lift, "arm_1_joint"]).error_units(tiago)
    assert tiago.model.joints[tiago.model.getJointId(lift)].shortname().startswith("JointModelP")
    assert units == ("m", "rad")


def test_metrics_report_a_pose_task_per_unit(tmp_path):
    doc = yaml.safe_load((SCENARIOS_DIR / "talos_reach.yaml").read_text())
    for level in doc["stack"]:
        for t in level:
            if t.get("frame") == "right_hand":
                t["mask"] = "pose"
    path = tmp_path / "reach_pose.yaml"
    path.write_text(yaml.safe_dump(doc))
    m = run(load_config(path), duration=0.05)
    hand, com, torso = m["tasks"]["right_hand"], m["tasks"]["com"], m["tasks"]["torso"]
    assert (hand["unit"], com["unit"], torso["unit"]) == ("m+rad", "m", "rad")
    assert "parts" not in com and set(hand["parts"]) == {"m", "rad"}
    pos, rot = hand["parts"]["m"], hand["parts"]["rad"]
    assert pos["unit"] == "m" and rot["unit"] == "rad"
    # the parts are the norms of the 6-vector's halves: they add up in quadrature to the whole
    assert math.hypot(pos["final"], rot["final"]) == pytest.approx(hand["final"], rel=1e-12)
    assert pos["max"] <= hand["max"] * (1 + 1e-12) and rot["max"] <= hand["max"] * (1 + 1e-12)
    assert hand["max"] <= math.hypot(pos["max"], rot["max"]) * (1 + 1e-12)
