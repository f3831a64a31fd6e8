"""Collision monitoring: the run's metrics cover every monitored pair (not only the rows'), and
MuJoCo's own contact list sees the links paired with obstacles (their hulls added as geoms)."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from wbc.runner.loop import ScenarioRun, run
from wbc.scenario.loader import load_config


def test_distance_min_covers_pairs_without_a_row():
    """TIAGo's first 0.2 s: no arm link within the influence distance of the table (no row), yet
    the metrics give the closest pair's true distance, as the exact distances of all pairs say."""
    sc = load_config("tiago_table_reach")
    task = next(t for t in sc.stack if t.kind == "collision_avoidance")
    m = run(sc, duration=0.2)
    assert m["collision_pairs_active_max"] == 0
    assert task.influence < m["collision_distance_min"] < 1.0
    d = task.model.all_distances(sc.robot.q_default)
    assert m["collision_distance_min"] == pytest.approx(d.min(), abs=2e-3)
    k = int(np.argmin(d))
    assert m["collision_closest_pair"] == [task.model.names[i] for i in task.model.pairs[k]]


@pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco not installed")
def test_mujoco_contact_list_sees_an_arm_link_in_the_table():
    """MuJoCo's model keeps no URDF collision geometry; the run adds the hulls of the links the
    collision task pairs with obstacles. No contact at the start; with the base moved 0.6 m
    forward the arm is in the table: MuJoCo names the link and the table, at coal's depth."""
    sc = load_config("tiago_table_reach")
    task = next(t for t in sc.stack if t.kind == "collision_avoidance")
    r = ScenarioRun(sc, simulator="mujoco", duration=0.01)
    sim = r.sim
    assert sim.link_contacts() == []
    q = sim.q.copy()
    q[0] += 0.6
    sim.set_state(q, np.zeros(sim.model.nv))
    touching = sim.link_contacts()
    assert touching and all(other.endswith("table") for _, other, _ in touching)
    d = task.model.all_distances(q)
    deepest = min(dist for _, _, dist in touching)
    assert deepest == pytest.approx(d.min(), abs=1e-3) and deepest < 0


def test_smallest_distances_are_those_of_all_pairs():
    """The monitor's pruned search (exact distances in order of the bounding spheres' lower
    bound) gives the five smallest distances of all of Talos's 728 pairs, at random postures."""
    from wbc.collision.model import CollisionModel
    from wbc.robot.loader import load_robot

    robot = load_robot("talos")
    cm = CollisionModel(robot)
    data, gd = robot.model.createData(), cm.new_geometry_data()
    rng = np.random.default_rng(7)
    for _ in range(6):
        q = robot.random_configuration(rng, margin=0.0)
        d_all = cm.all_distances(q, data, gd)
        d, ks = cm.smallest_distances(q, 5, data, gd)
        np.testing.assert_allclose(d, np.sort(d_all)[:5], atol=1e-6)    # coal's EPA, warm-started: 1e-7 m
        np.testing.assert_allclose(d_all[ks], d, atol=1e-6)
