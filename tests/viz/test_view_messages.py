"""The messages between the control process and the live view's drawing process, without pickle:
the scene's description (:func:`wbc.viz.live.view_spec`) and the page's commands (the drawing
process's :class:`~wbc.viz.drawing.Poster`) cross a real ``multiprocessing`` connection as JSON
bytes (:func:`wbc.viz.jsonable.send` / ``receive``) while the connection's pickler is made to
fail; what arrives is what was sent (the pinocchio model equal to the controller's, the surfaces,
the task sliders' ranges; a target's array bit for bit, a push's force and duration) and the
mailbox key comes back as the tuple the control loop's commands are keyed by."""

from __future__ import annotations

import socket
from multiprocessing import reduction
from multiprocessing.connection import Connection
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from wbc import jsonable

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def pipe(monkeypatch):
    """Two ends of a socket pair as Connections, the pickler made to fail."""

    def refuse(*_a, **_k):
        raise AssertionError("pickle used on the live view's connection")

    monkeypatch.setattr(reduction.ForkingPickler, "dumps", classmethod(refuse))
    monkeypatch.setattr(reduction.ForkingPickler, "loads", refuse)
    a, b = socket.socketpair()
    ca, cb = Connection(a.detach()), Connection(b.detach())
    yield ca, cb
    ca.close()
    cb.close()


def test_the_pickler_is_really_refused(pipe):
    ca, _ = pipe
    with pytest.raises(AssertionError, match="pickle used"):
        ca.send(("post", "pause", True))


def test_the_scene_description_arrives_as_plain_data(pipe):
    from wbc.scenario.loader import load_config
    from wbc.viz.live import view_spec

    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / "tiago_table_reach.yaml")
    spec = view_spec(sc.robot, sc.environment, sc.stack, frames=("gripper",), overlays={"footsteps": True})
    ca, cb = pipe
    jsonable.send(ca, spec)
    got = jsonable.receive(cb)
    model = pin.Model()
    model.loadFromString(got["model"])
    assert model == sc.robot.model and model.nframes == sc.robot.model.nframes
    kinds = sorted(d["kind"] for d in got["environment"])
    assert kinds == ["box", "halfspace"]
    table = next(d for d in got["environment"] if d["kind"] == "box")
    box = next(s for s in sc.environment if s.name == table["name"])
    np.testing.assert_array_equal(table["center"], box.center)
    np.testing.assert_array_equal(table["size"], box.size)
    assert [t["name"] for t in got["tasks"]] == [t.name for t in sc.stack]
    assert [list(t["kp_range"]) if t["kp_range"] else None for t in got["tasks"]] == \
        [list(t["kp_range"]) if t["kp_range"] else None for t in spec["tasks"]]
    assert got["push_frames"] == ["gripper"] and got["overlays"] == {"footsteps": True}


def test_page_commands_arrive_keyed_as_posted(pipe):
    from wbc.viz.drawing import Poster
    from wbc.viz.live import page_command

    ca, cb = pipe
    poster = Poster(ca)
    target = np.array([0.412345678901234, -0.2, 1.1e-17])
    force = np.array([0.0, 30.0, 0.0])
    poster.post(("target", "right_hand"), target)
    poster.post(("push", "base"), (force, 0.25))
    poster.post("pause", True)
    got = [page_command(jsonable.receive(cb)) for _ in range(3)]
    assert poster.posted == 3
    (k1, v1), (k2, v2), (k3, v3) = got
    assert k1 == ("target", "right_hand") and isinstance(k1, tuple) and hash(k1) == hash(("target", "right_hand"))
    assert v1.dtype == np.float64 and np.array_equal(v1, target)
    assert k2 == ("push", "base") and np.array_equal(v2[0], force) and v2[1] == 0.25
    assert (k3, v3) == ("pause", True)
