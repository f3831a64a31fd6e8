"""`wbc run` warns once per near-singular level, naming the level's tasks, the directions
(task components) and the joints that lose rank (wbc.cli.main, metrics' ``singularities``):
the Panda driven out to its workspace boundary (panda_reach_boundary; by 1.2 s the hand is
past its reach with projection, by 1.6 s with hqp and weighted; the weighted QP names the hand
level by its own rows, which it folds with the posture)."""

from __future__ import annotations

import re

import pytest

from wbc.cli.main import main


@pytest.mark.parametrize("solver", ["hqp", "projection", "weighted"])
def test_run_warns_once_naming_the_task_and_the_joints(capsys, solver):
    main(["run", "panda_reach_boundary", "--duration", "1.6", "--solver", solver])
    err = capsys.readouterr().err
    warnings = [ln for ln in err.splitlines() if "near-singular" in ln]
    assert len(warnings) == 1, err                      # once, for the hand's level alone
    w = warnings[0]
    assert w.startswith("wbc: warning: level 1 (hand)") and "below the damping threshold" in w, w
    assert re.search(r" in hand\[[0-2]\]", w), w                 # a direction: a row of the hand task
    joints = re.search(r"\(joints ([^)]*)\)", w)
    assert joints and all(j.strip().startswith("panda_joint") for j in joints.group(1).split(",")), w
