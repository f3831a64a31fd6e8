"""Per-geometry primitives (wbc.collision.primitives): the collision file's schema, the fit's containment, the
distance rows of primitive pairs against finite differences, and the opt-in."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from wbc.collision.hulls import hull_vertices
from wbc.collision.model import CollisionModel
from wbc.collision.primitives import fit_box, fit_capsule, read_primitives
from wbc.errors import RobotDefinitionError
from wbc.robot.loader import load_robot

NAMES = ["arm_left_2_link_0", "torso_2_link_0"]


def _error(tmp_path, text: str) -> RobotDefinitionError:
    path = tmp_path / "r.collisions.yaml"
    path.write_text("pairs: []\nprimitives:\n" + text)
    with pytest.raises(RobotDefinitionError) as e:
        read_primitives(path, NAMES)
    assert e.value.file == path
    return e.value


@pytest.mark.parametrize("text, key, line, expected", [
    ("  arm_left_2_link_0: {type: cone, radius: 0.1}\n", "primitives.arm_left_2_link_0.type", 3,
     "one of ['capsule', 'cylinder', 'sphere', 'box']"),
    ("  arm_left_2_link_0: {type: capsule, radius: -0.1, length: 0.2}\n", "primitives.arm_left_2_link_0.radius", 3,
     "a number in (0, 10] (m), got -0.1"),
    ("  torso_2_link_0: {type: sphere, radius: 0.1}\n  arm_left_2_link_0: {type: capsule, radius: 0.1}\n",
     "primitives.arm_left_2_link_0.length", 4, "missing"),
    ("  arm_left_2_link_0: {type: sphere, radius: 0.1, length: 0.3}\n", "primitives.arm_left_2_link_0.length", 3,
     "unknown key"),
    ("  arm_left_2_link_0: {type: box, size: [0.1, 0.2]}\n", "primitives.arm_left_2_link_0.size", 3,
     "a list of 3 numbers"),
    ("  arm_left_2_link_0:\n    type: sphere\n    radius: 0.1\n    xyz: [0, 0, nan]\n",
     "primitives.arm_left_2_link_0.xyz[2]", 6, "a number"),
    ("  arm_left_9_link_0: {type: sphere, radius: 0.1}\n", "primitives.arm_left_9_link_0", 3,
     "arm_left_2_link_0"),
])
def test_schema_errors_name_file_line_key_and_expected(tmp_path, text, key, line, expected):
    e = _error(tmp_path, text)
    assert e.key == key and e.line == line, (e.key, e.line, str(e))
    assert expected in str(e), str(e)


def _talos_hulls():
    cm = CollisionModel(load_robot("talos"), self_collision=False)
    return {g.name: hull_vertices(g.geometry) for g in cm.geometry_model.geometryObjects}


def _segment_distance(P, r_len):
    """Distance of points P (local frame, axis z) to the segment z ∈ [−L/2, L/2]."""
    z = np.clip(P[:, 2], -r_len / 2, r_len / 2)
    return np.linalg.norm(P - np.column_stack([np.zeros(len(P)), np.zeros(len(P)), z]), axis=1)


@pytest.mark.parametrize("name", ["arm_left_2_link_0", "arm_right_4_link_0", "gripper_left_fingertip_1_link_0",
                                  "torso_2_link_0", "head_2_link_0"])
def test_fitted_capsule_and_box_contain_every_hull_vertex_and_are_tight(name):
    P = _talos_hulls()[name]
    r, length, M = fit_capsule(P)
    local = (P - M.translation) @ M.rotation
    d = _segment_distance(local, length)
    assert (d <= r + 1e-12).all()
    assert (d > r - 1e-3).any()                     # 1 mm less radius leaves a vertex out: the fit is tight
    size, B = fit_box(P)
    local = np.abs((P - B.translation) @ B.rotation)
    assert (local <= size / 2 + 1e-12).all()
    assert ((local > size / 2 - 1e-3).any(axis=0)).all()    # each side touches a vertex (within 1 mm)


@pytest.fixture(scope="module")
def talos_primitives(tmp_path_factory):
    """Talos with a collision file of its own: the bundled pairs and primitives."""
    robot = load_robot("talos")
    d = tmp_path_factory.mktemp("talos")
    shutil.copy(robot.source.with_suffix(".collisions.yaml"), d / "talos.collisions.yaml")
    robot.source = d / "talos.yaml"
    return robot


def test_primitives_are_opt_in_and_replace_the_named_geometries(talos_primitives):
    robot = talos_primitives
    hulls = CollisionModel(robot)
    prims = CollisionModel(robot, primitives=True)
    assert hulls.primitive_names == [] and len(prims.primitive_names) > 0
    kinds = {type(g.geometry).__name__ for g in hulls.geometry_model.geometryObjects}
    assert "Capsule" not in kinds
    by_name = {g.name: g for g in prims.geometry_model.geometryObjects}
    assert {type(by_name[n].geometry).__name__ for n in prims.primitive_names} <= {"Capsule", "Box"}
    # each primitive contains its hull: the primitives' distance is never above the hulls' (random states)
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = robot.random_configuration(rng, margin=0.0)
        assert (prims.all_distances(q) <= hulls.all_distances(q) + 1e-6).all()


def test_capsule_pair_distance_jacobian_matches_finite_differences(talos_primitives):
    from tests.tasks.test_task_jacobians import SPEED, check_collision, random_state
    from wbc.problem.rows import Layout
    from wbc.tasks.collision_avoidance import CollisionAvoidance

    robot = talos_primitives
    task = CollisionAvoidance(influence=0.08, safety=0.01, geometry="primitives", max_rows=1000)
    task.bind(robot)
    caps = {i for i, g in enumerate(task.model.geometry_model.geometryObjects)
            if type(g.geometry).__name__ == "Capsule"}
    rng = np.random.default_rng(5)
    for _ in range(200):
        q, v = random_state(robot, rng, speed=SPEED)
        robot.update(q, v)
        rows = task.model.distance_rows(robot, task.influence)
        both = [k for k in rows.pairs if set(task.model.pairs[k].tolist()) <= caps]
        if both:
            break
    assert both, "no capsule-capsule pair within the influence distance in 200 random states"
    check_collision(robot, task, Layout(nv=robot.nv), q, v)


def test_cli_fits_primitives_into_the_collision_file_and_keeps_its_pairs(tmp_path, capsys):
    from wbc.cli.main import main
    from wbc.collision.pairs import read_pair_file

    robot = load_robot("panda")
    shutil.copy(robot.source, tmp_path / "panda.yaml")
    shutil.copy(robot.source.with_suffix(".collisions.yaml"), tmp_path / "panda.collisions.yaml")
    pairs = read_pair_file(robot)
    assert main(["robot", "collisions", str(tmp_path / "panda.yaml"), "--primitives", "--max-excess", "0.05"]) == 0
    out = capsys.readouterr().out
    assert "geometries get a primitive" in out
    copy = load_robot(str(tmp_path / "panda.yaml"))
    assert read_pair_file(copy) == pairs
    prims = read_primitives(tmp_path / "panda.collisions.yaml")
    assert prims and all(p.excess is not None and p.excess <= 0.05 for p in prims.values())
    assert main(["robot", "collisions", "panda", "--primitives", "--max-excess", "2"]) == 2
    assert "--max-excess" in capsys.readouterr().err


def test_asking_for_primitives_that_do_not_exist_is_an_error():
    from wbc.errors import TaskDefinitionError
    from wbc.tasks.collision_avoidance import CollisionAvoidance

    with pytest.raises(TaskDefinitionError, match=r"one of \['hulls', 'primitives'\], got 'capsules'") as e:
        CollisionAvoidance(geometry="capsules")
    assert e.value.key == "geometry"
    robot = load_robot("tiago")             # its collision file has pairs, no primitives
    with pytest.raises(RobotDefinitionError, match="no collision primitives") as e2:
        CollisionAvoidance(geometry="primitives").bind(robot)
    assert str(e2.value.file).endswith("tiago.collisions.yaml")


def test_rewriting_the_pairs_keeps_the_primitives(tmp_path):
    from wbc.collision.pairs import pair_file, read_pair_file, write_pair_file

    robot = load_robot("talos")
    shutil.copy(pair_file(robot), tmp_path / "talos.collisions.yaml")
    robot.source = tmp_path / "talos.yaml"
    before = read_primitives(pair_file(robot))
    pairs = read_pair_file(robot)[:10]
    write_pair_file(robot, pairs, {"kept": 10})
    after = read_primitives(pair_file(robot))
    assert read_pair_file(robot) == pairs and sorted(after) == sorted(before) and len(after) == 20
    for name, p in before.items():
        assert after[name].kind == p.kind and after[name].placement.isApprox(p.placement)
