"""What the live page draws, and how big: the robot's meshes thinned on ``PageOptions.mesh_cell``'s
grid for the page (a browser rendering WebGL in software pays per triangle, every frame), the full
meshes with 0; the canvas's pixel ratio in the page's address; bad values refused by name.
"""

from __future__ import annotations

import pickle
from multiprocessing import Pipe

import numpy as np
import pytest

pytest.importorskip("viser", reason="the live view needs viser")


def _sent_meshes(sc, cell: float):
    """(vertices, faces) of each robot mesh a Drawer sent to its viser scene with ``mesh_cell``."""
    from wbc.viz.drawing import Drawer, Poster
    from wbc.viz.live import view_spec

    spec = view_spec(sc.robot, sc.environment, sc.stack, port=8590, mesh_cell=cell)
    mine, theirs = Pipe()
    drawer = Drawer(pickle.loads(pickle.dumps(spec)), Poster(mine))
    try:
        return [(np.asarray(h.vertices), np.asarray(h.faces)) for _, h in drawer.visuals]
    finally:
        drawer.server.stop()
        mine.close()
        theirs.close()


def test_the_page_meshes_are_the_robots_thinned_on_the_grid():
    from scipy.spatial import cKDTree

    from wbc.scenario.loader import load_config
    from wbc.viz.live import LIVE_MESH_CELL
    from wbc.viz.meshes import geometry_mesh, visual_model

    sc = load_config("tiago_reach")
    full = [m for m in map(geometry_mesh, visual_model(sc.robot).geometryObjects) if m is not None]
    sent_full = _sent_meshes(sc, 0.0)
    sent = _sent_meshes(sc, LIVE_MESH_CELL)
    assert len(sent) == len(sent_full) == len(full)
    # 0: the full meshes, as read
    for (v, f), (v0, f0) in zip(sent_full, full):
        assert np.array_equal(f, f0) and np.allclose(v, v0)
    n_full, n = sum(len(f) for _, f in sent_full), sum(len(f) for _, f in sent)
    print(f"tiago: {n_full} triangles full, {n} at {LIVE_MESH_CELL} m")
    assert n < 0.5 * n_full
    # the same shape: each vertex sent is the mean of the original vertices of one grid cell, so
    # within the cell's diagonal of one of them; and every original vertex is within the
    # diagonal of a sent one (no part of the robot dropped)
    diag = np.sqrt(3.0) * LIVE_MESH_CELL
    for (v, f), (v0, _) in zip(sent, full):
        assert len(f) > 0 and f.max() < len(v)
        assert np.max(cKDTree(v0).query(v)[0]) <= diag + 1e-6
        assert np.max(cKDTree(v).query(v0)[0]) <= diag + 1e-6


def test_the_pixel_ratio_is_in_the_page_address():
    from wbc.viz.live import page_url

    assert page_url("127.0.0.1", 8080) == "http://127.0.0.1:8080/"
    assert page_url("127.0.0.1", 8081, 0.5) == "http://127.0.0.1:8081/?fixedDpr=0.5"
    assert page_url("::1", 8080, 1.25) == "http://[::1]:8080/?fixedDpr=1.25"


@pytest.mark.parametrize("bad", [{"mesh_cell": -0.01}, {"pixel_ratio": 0.0}, {"pixel_ratio": -1.0},
                                 {"pixel_ratio": float("nan")}])
def test_bad_page_values_are_refused_by_name(bad):
    from wbc.errors import WbcError
    from wbc.scenario.loader import load_config
    from wbc.viz.live import LiveView

    sc = load_config("panda_reach_boundary")
    with pytest.raises(WbcError, match=next(iter(bad))):
        LiveView(sc.robot, sc.environment, sc.stack, port=8591, **bad)
