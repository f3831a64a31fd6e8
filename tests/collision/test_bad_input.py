"""Bad collision input: a precise error (file, line, key path; exit 2 from the CLI), and a robot
that starts in collision: a warning naming the pair and its penetration, then pushed out."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest

from wbc.cli.main import main
from wbc.collision.model import CollisionModel
from wbc.errors import CollisionWarning, ConfigError, RobotDefinitionError
from wbc.robot.loader import load_robot
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config

PANDA = """name: bad
robot: {robot}
control: {{dt: 0.001}}
duration: 0.5
environment:
  - {{type: ground}}
  - {{type: sphere, name: ball, center: {center}, radius: 0.05}}
stack:
  - - {{type: joint_limits}}
    - {{type: torque_limits}}
    - type: collision_avoidance
      influence: {influence}
      safety: 0.02
      environment: true
      links: {links}
  - - {{type: posture, kp: 10.0}}
"""


def _write(tmp_path, **kw):
    spec = dict(robot="panda", center="[0.382, 0.175, 0.515]", influence=0.06,
                links="[panda_link7, panda_hand]")
    spec.update(kw)
    path = tmp_path / "bad.yaml"
    path.write_text(PANDA.format(**spec))
    return path


@pytest.mark.parametrize("change, key, words", [
    ({"links": "[panda_link7, no_such_link]"}, "stack[0][2].links", "no_such_link"),
    ({"influence": 0.02}, "stack[0][2].safety", "must be below influence"),
    ({"influence": -0.05}, "stack[0][2].influence", "in (0, 1] (m), got -0.05"),
])
def test_bad_collision_task_names_file_line_and_key(tmp_path, capsys, change, key, words):
    path = _write(tmp_path, **change)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    msg = str(err.value)
    assert str(path) in msg and key in msg and words in msg
    assert err.value.line is not None and 9 <= err.value.line <= 16
    assert main(["validate", str(path)]) == 2
    assert key in capsys.readouterr().err


def test_negative_obstacle_radius(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(PANDA.format(robot="panda", center="[0.4, 0.2, 0.5]", influence=0.06, links="[panda_hand]")
                    .replace("radius: 0.05", "radius: -0.05"))
    with pytest.raises(ConfigError, match=r"environment\[1\]\.radius"):
        load_config(path)


def test_a_link_without_collision_geometry(tmp_path):
    """TIAGo's base_footprint has no <collision>: naming it is an error that lists the links that have some."""
    path = tmp_path / "bad.yaml"
    path.write_text(PANDA.format(robot="tiago", center="[1.0, 0.0, 0.6]", influence=0.06,
                                 links="[base_footprint]"))
    with pytest.raises(ConfigError, match="no collision geometry") as err:
        load_config(path)
    assert "stack[0][2].links" in str(err.value)


def test_a_pair_file_naming_an_unknown_geometry(tmp_path):
    robot = load_robot("tiago")
    robot.source = tmp_path / "tiago.yaml"
    shutil.copy(load_robot("tiago").source, robot.source)
    (tmp_path / "tiago.collisions.yaml").write_text("robot: tiago\npairs:\n  - [arm_1_link_0, arm_4_link_0]\n"
                                                    "  - [arm_1_link_0, no_such_geometry]\n")
    with pytest.raises(RobotDefinitionError) as err:
        CollisionModel(robot)
    msg = str(err.value)
    assert "tiago.collisions.yaml" in msg and "pairs[1]" in msg and "no_such_geometry" in msg and ":4:" in msg


def test_collisions_on_a_robot_without_collision_geometry(tmp_path):
    """A URDF with no <collision> element: the error says so (exit 2 from `wbc validate`)."""
    import re

    src = load_robot("panda")
    urdf = re.sub(r"<collision>.*?</collision>", "", src.urdf_path.read_text(), flags=re.S)
    (tmp_path / "bare.urdf").write_text(urdf)
    robot_yaml = src.source.read_text().replace(
        "urdf: {package: example-robot-data, path: robots/panda_description/urdf/panda.urdf}", "urdf: bare.urdf")
    (tmp_path / "bare.yaml").write_text(robot_yaml)
    path = _write(tmp_path, robot="bare.yaml")
    with pytest.raises(ConfigError, match="no <collision>"):
        load_config(path)
    assert main(["validate", str(path)]) == 2


def test_starting_in_collision_warns_and_is_pushed_out(tmp_path):
    """The hand starts 1 cm inside the sphere: a warning names the pair and its penetration; the
    damper pushes it out (finite torques every cycle, the distance grows to d_s − 1 mm)."""
    robot = load_robot("panda")
    robot.update(robot.q, np.zeros(robot.nv))
    hand = robot.frame_placement(robot.frame_id("hand")).translation
    centre = hand + np.array([0.0, 0.0, 0.03])
    path = _write(tmp_path, center=str(centre.tolist()), links="[panda_hand]")
    sc = load_config(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = ScenarioRun(sc)
    msgs = [str(w.message) for w in caught if issubclass(w.category, CollisionWarning)]
    assert msgs and "panda_hand_0/ball" in msgs[0] and "penetration" in msgs[0]
    obs = next(o for o in r.observers if type(o).__name__ == "CollisionObserver")
    d0 = obs.monitor.distances(r.sim.q).min()
    assert d0 < 0
    for k in range(r.n):
        assert r.cycle(k)
        assert np.all(np.isfinite(r.last_sol.tau))
    assert obs.monitor.last[0].min() >= 0.02 - 1e-3
