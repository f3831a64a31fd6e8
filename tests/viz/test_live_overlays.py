"""The live view's run overlays (:mod:`wbc.viz.run_overlays`, :mod:`wbc.viz.overlays`), drawn by a
:class:`~wbc.viz.drawing.Drawer` in this process (its viser server on a free port, no browser):

- a walk (g1_walk): each planned footstep's cross, the planned ZMP and DCM and the measured centre
  of pressure, which lies inside the loaded contact points' hull; switched off, hidden;
- the collision task's witness segments (panda_obstacle): p₁–p₂ of the closest pairs, their
  lengths the pairs' distances, coloured by distance;
- a force task's desired and measured forces (tiago_wipe): arrows from the contact point, 1 cm
  per N; a glass's frame (tiago_glass): its axes at the frame's placement;
- the contact-force arrows: one per loaded contact point.
"""

from __future__ import annotations

import pickle
from multiprocessing import Pipe
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("viser", reason="the live view needs viser")


def _run(name: str, cycles: int):
    from wbc.runner.loop import ScenarioRun
    from wbc.runner.options import RunOptions
    from wbc.scenario.loader import load_config

    sc = load_config(name)
    r = ScenarioRun(sc, RunOptions(duration=cycles * sc.dt + 1.0))
    for k in range(cycles):
        assert r.cycle(k)
    return sc, r, cycles * sc.dt


def _drawn(sc, r, t: float, port: int):
    """(drawer, decoded snapshot) of the run's state now, drawn once."""
    from wbc import jsonable
    from wbc.runner.interactive import snapshot
    from wbc.viz import shown_frames
    from wbc.viz.drawing import Drawer, Poster
    from wbc.viz.live import encode, view_spec
    from wbc.viz.run_overlays import overlay_data, overlay_names

    spec = view_spec(sc.robot, sc.environment, sc.stack, port=port, frames=tuple(sc.robot.frames),
                     shown_frames=shown_frames(sc), overlays=overlay_names(sc))
    mine, _theirs = Pipe()
    drawer = Drawer(pickle.loads(pickle.dumps(spec)), Poster(mine))
    drawer.pipe = (mine, _theirs)       # kept open while the drawer lives
    snap = SimpleNamespace(**jsonable.decode(encode(snapshot(r, t, extras=overlay_data))))
    drawer.draw(snap)
    return drawer, snap


def test_walk_footsteps_zmp_dcm_and_contact_forces():
    from scipy.spatial import Delaunay

    sc, r, t = _run("g1_walk", 400)
    w = next(o.walker for o in r.observers if hasattr(o, "walker"))
    drawer, snap = _drawn(sc, r, t, 8311)
    try:
        assert set(drawer.overlays) >= {"footsteps", "ZMP / DCM", "contact forces", "support polygon"}
        steps = drawer.extra.handles["footsteps"]
        assert steps.points.shape == (2 * len(w.plan.steps), 2, 3) and len(w.plan.steps) > 2
        centres = steps.points.reshape(-1, 4, 3).mean(axis=1)        # each cross's centre
        np.testing.assert_allclose(centres[:, :2], [(s.x, s.y) for s in w.plan.steps], atol=1e-5)
        dots = drawer.extra.handles["ZMP / DCM"].points
        assert dots.shape == (3, 3)
        # viser keeps a point cloud's points in float16: 11 significant bits
        np.testing.assert_allclose(dots[0, :2], w.preview.zmp(t), rtol=1e-3, atol=1e-4)
        np.testing.assert_allclose(dots[1, :2], w.preview.dcm(t), rtol=1e-3, atol=1e-4)
        loaded = snap.points[np.linalg.norm(snap.forces, axis=1) > 1e-3]
        assert Delaunay(loaded[:, :2]).find_simplex(dots[2, :2]) >= 0       # the centre of pressure
        from wbc.viz.drawing import MIN_ARROW

        n = np.linalg.norm(snap.forces, axis=1)
        long = n / drawer.force_scale * 1e-3 > MIN_ARROW          # arrows of 1 mm or more
        forces = drawer._arrows["/overlay/forces"]
        assert forces.points.shape == (long.sum(), 2, 3) and long.sum() >= 3
        np.testing.assert_allclose(forces.points[:, 1] - forces.points[:, 0],
                                   snap.forces[long] / drawer.force_scale * 1e-3, atol=1e-5)
        drawer.handle(("overlay", "footsteps", False))
        drawer.draw(snap)
        assert not drawer.extra.handles["footsteps"].visible
        assert drawer.controls.overlay_boxes["footsteps"].value is False
    finally:
        drawer.server.stop()


def test_collision_witness_segments():
    from wbc.viz.collisions import witness_color

    sc, r, t = _run("panda_obstacle", 300)
    task = next(t_ for t_ in sc.stack if t_.kind == "collision_avoidance")
    rows, order = task.last
    assert len(order) > 0, "no pair within the influence distance at this time"
    drawer, _ = _drawn(sc, r, t, 8312)
    try:
        h = drawer.extra.handles["collision pairs"]
        n = min(len(order), 5)
        assert h.points.shape == (n, 2, 3)
        lengths = np.linalg.norm(h.points[:, 1] - h.points[:, 0], axis=1)
        np.testing.assert_allclose(lengths, np.abs(rows.d[order[:n]]), atol=1e-5)
        c = witness_color(float(rows.d[order[0]]), task.safety, task.influence)
        assert tuple(h.colors[0, 0]) == ((c >> 16) & 255, (c >> 8) & 255, c & 255)
    finally:
        drawer.server.stop()


def test_force_task_arrows_and_glass_axes():
    from wbc.viz.task_forces import task_forces

    sc, r, t = _run("tiago_wipe", 300)
    task = next(t_ for t_ in sc.stack if t_.kind == "force")
    point, desired, measured = task_forces(sc.robot, sc.robot.data, task, sc.stack)
    drawer, _ = _drawn(sc, r, t, 8313)
    try:
        arrows = drawer._arrows["/overlay/run/force_task_λ"].points
        assert arrows.shape == (2, 2, 3)
        np.testing.assert_allclose(arrows[:, 0], [point, point], atol=1e-5)
        np.testing.assert_allclose(arrows[0, 1] - arrows[0, 0], desired * 1e-2, atol=1e-5)     # 1 cm per N
        np.testing.assert_allclose(arrows[1, 1] - arrows[1, 0], measured * 1e-2, atol=1e-5)
    finally:
        drawer.server.stop()
    sc, r, t = _run("tiago_glass", 50)
    drawer, snap = _drawn(sc, r, t, 8314)
    try:
        ((name, fid, axes),) = drawer.shown_frames
        data = sc.robot.model.createData()
        pin.framesForwardKinematics(sc.robot.model, data, snap.q)
        np.testing.assert_allclose(axes.position, data.oMf[fid].translation, atol=1e-6)
        assert name == sc.interaction.glass_frame
    finally:
        drawer.server.stop()
