"""Self-pair filtering (wbc.collision.pairs) and `wbc robot collisions ROBOT`."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from wbc.collision.model import CollisionModel
from wbc.collision.pairs import default_self_pairs, read_pair_file, srdf_path, write_pair_file
from wbc.collision.sampling import sample_self_pairs
from wbc.errors import RobotDefinitionError
from wbc.robot.loader import load_robot


def test_default_pairs_drop_srdf_disabled_and_adjacent_links():
    robot = load_robot("talos")
    cm = CollisionModel(robot, self_pairs="default")
    pairs = {frozenset(p) for p in default_self_pairs(robot, cm.geometry_model, cm.n_robot)}
    model, links = robot.model, dict(zip(cm.names, cm.links))
    joint = {g.name: g.parentJoint for g in cm.geometry_model.geometryObjects}
    disabled = set()
    import xml.etree.ElementTree as ET

    for e in ET.parse(srdf_path(robot)).getroot().iter("disable_collisions"):
        disabled.add(frozenset((e.get("link1"), e.get("link2"))))
    assert disabled
    for p in pairs:
        a, b = tuple(p)
        assert frozenset((links[a], links[b])) not in disabled
        ja, jb = joint[a], joint[b]
        assert ja != jb and model.parents[ja] != jb and model.parents[jb] != ja
    assert len(pairs) == len(cm.pairs) > 0


def test_sampled_pairs_are_those_that_come_within_the_influence(tmp_path):
    robot = load_robot("tiago")
    kept, summary = sample_self_pairs(robot, influence=0.05, samples=40, seed=1)
    cm = CollisionModel(robot, self_pairs="default")
    rng = np.random.default_rng(1)
    closest = np.full(len(cm.pairs), np.inf)
    for _ in range(40):
        closest = np.minimum(closest, cm.all_distances(robot.random_configuration(rng, margin=0.0)))
    expected = {(cm.names[a], cm.names[b]) for (a, b), d in zip(cm.pairs, closest) if d < 0.05}
    assert set(kept) == expected and 0 < len(kept) < summary["candidates"]

    robot.source = tmp_path / "tiago.yaml"
    shutil.copy(load_robot("tiago").source, robot.source)
    write_pair_file(robot, kept, summary)
    assert read_pair_file(robot) == kept
    assert len(CollisionModel(robot).pairs) == len(kept)
    (tmp_path / "tiago.collisions.yaml").write_text("pairs: [[arm_1_link_0, no_such_geometry]]\n")
    with pytest.raises(RobotDefinitionError, match="no_such_geometry"):
        CollisionModel(robot)
