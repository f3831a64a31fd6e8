"""A live run's commands (wbc.runner.interactive), without a browser: what a page posts reaches
the controller at the start of the next cycle, clamped to the valid ranges, the last post per key
winning; a target out of reach is sacrificed and named; disabling a task and moving it to another
level change the hierarchy the solver sees."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from wbc.runner.interactive import Mailbox, run_live
from wbc.runner.options import RunOptions
from wbc.scenario.loader import load_config
from wbc.tasks.tuning import gain_range, weight_range

ROOT = Path(__file__).resolve().parents[2]


def _reach():
    return load_config(ROOT / "wbc" / "data" / "scenarios" / "talos_reach.yaml")


def test_last_post_per_key_wins_across_threads():
    box = Mailbox()

    def tab(k):
        for i in range(200):
            box.post(("kp", "com"), (k, i))

    tabs = [threading.Thread(target=tab, args=(k,)) for k in range(2)]
    for t in tabs:
        t.start()
    for t in tabs:
        t.join()
    got = box.take()
    assert list(got) == [("kp", "com")] and got[("kp", "com")][1] == 199
    assert box.posted == 400 and box.take() == {}
    box.post("step", 2)
    box.post("step", 3)
    assert box.take() == {"step": 5}            # steps add up


def _live(sc, posts, duration=0.05, **kw):
    """Run ``sc`` unpaced with ``posts`` posted before the start; returns (metrics, snapshots)."""
    box = Mailbox()
    for key, value in posts:
        box.post(key, value)
    snaps = []
    m = run_live(sc, RunOptions(duration=duration), snaps.append, box, realtime=False, **kw)
    return m, snaps


def test_gains_and_weights_are_clamped_to_their_range():
    sc = _reach()
    com, hand = sc.stack["com"], sc.stack["right_hand"]
    top = gain_range(com, float(com.kp))[1]
    _live(sc, [(("kp", "com"), 1e9), (("kp", "right_hand"), -5.0), (("weight", "posture"), 0.0)], duration=0.01)
    assert com.kp == top and np.isclose(com.kd, 2 * np.sqrt(top))
    assert hand.kp == 0.0
    assert sc.stack["posture"].weight == weight_range(sc.stack["posture"])[0] > 0


def test_a_dragged_target_is_tracked_and_an_unreachable_one_sacrificed():
    sc = _reach()
    far = np.eye(4)
    far[:3, 3] = (3.0, -0.5, 1.0)               # 3 m ahead: out of the arm's reach
    m, snaps = _live(sc, [(("target", "right_hand"), far[:3, 3])], duration=0.3)
    assert np.allclose(sc.stack["right_hand"].target.translation, far[:3, 3])   # the trajectory no longer drives it
    assert np.allclose(snaps[-1].targets["right_hand"][:3, 3], far[:3, 3])
    sacrificed = {n for d in snaps[-1].sol.diagnostics for n in d.sacrificed}
    assert "right_hand" in sacrificed
    assert not m["fell"] and m["solver_failures"] == 0


def test_disabling_and_moving_tasks_change_the_hierarchy():
    sc = _reach()
    box = Mailbox()
    box.post(("enabled", "left_hand"), False)
    box.post(("level", "torso"), 1)
    snaps: list = []

    def publish(snap):             # after the first snapshot (33 cycles), the page enables it again
        snaps.append(snap)
        if len(snaps) == 1:
            box.post(("enabled", "left_hand"), True)

    run_live(sc, RunOptions(duration=0.05), publish, box, realtime=False)
    first, last = snaps[0], snaps[-1]
    assert not any("left_hand" in lvl for lvl in first.levels) and first.disabled == ["left_hand"]
    assert "torso" in first.levels[1] and "com" in first.levels[1]
    assert [d.tasks for d in first.sol.diagnostics][1] == first.levels[1]      # what the solver saw
    assert last.disabled == [] and "left_hand" in last.levels[2]               # back at its level


def test_pause_and_step_hold_simulated_time():
    sc = _reach()
    box = Mailbox()
    box.post("pause", True)
    box.post("step", 3)
    snaps: list = []
    done = threading.Event()
    out = {}

    def serve():
        out["m"] = run_live(sc, RunOptions(duration=1.0), snaps.append, box, realtime=False)
        done.set()

    threading.Thread(target=serve, daemon=True).start()
    assert not done.wait(1.5)                   # paused after 3 cycles: the run does not end
    assert snaps and snaps[-1].paused and snaps[-1].t == pytest.approx(3 * sc.dt)
    box.post("stop", True)
    assert done.wait(30)
    assert out["m"]["duration"] == pytest.approx(3 * sc.dt)
