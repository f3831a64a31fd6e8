"""What a run shows in the live view beyond the robot, its contacts and its CoM, gathered in the
control process as plain arrays (:mod:`wbc.viz.overlays` draws them in the drawing process).

:func:`overlay_names` gives the overlays a scenario has (known before it runs: the page's
checkboxes); :func:`overlay_data` reads them from a running
:class:`~wbc.runner.loop.ScenarioRun` (its stack, simulator and observers, read only; called
with each published snapshot, every ``1/fps`` s of simulated time):

- ``collision pairs``: the collision task's :data:`WITNESSES` closest pairs' witness segments
  p₁–p₂ of its last cycle, coloured by distance (:func:`wbc.viz.collisions.witness_color`);
- ``force task λ``: per force task, its desired S_f λ_D (teal) and measured S_f λ_m (pink)
  forces as arrows from the contact point, 1 cm per ``TASK_FORCE_SCALE`` N;
- ``footsteps``: the walk's planned footsteps, a cross per step along and across the foot's
  yaw (left blue, right red, those already taken grey);
- ``ZMP / DCM``: the walk's planned ZMP (orange) and DCM (purple) from its preview, and the
  measured centre of pressure of the contact forces (black), on the ground.
"""

from __future__ import annotations

import numpy as np

from ..tasks.collision_avoidance import CollisionAvoidance
from ..tasks.force import Force
from .collisions import witness_color
from .task_forces import task_forces

WITNESSES = 5               # closest pairs drawn
TASK_FORCE_SCALE = 1.0      # N per cm of a force task's arrow
STEP_CROSS = (0.10, 0.05)   # m: half the footstep cross's length along and across the foot
SIDE_COLORS = {"left": (46, 134, 222), "right": (231, 76, 60)}
TAKEN = (150, 150, 150)
ZMP, DCM, COP = (243, 156, 18), (142, 68, 173), (20, 20, 20)
DESIRED, MEASURED = (22, 160, 133), (216, 27, 96)


def overlay_names(sc) -> dict[str, bool]:
    """The run overlays scenario ``sc`` has, each shown at start."""
    names = {}
    if any(isinstance(t, CollisionAvoidance) for t in sc.stack):
        names["collision pairs"] = True
    if any(isinstance(t, Force) for t in sc.stack):
        names["force task λ"] = True
    if getattr(sc, "walk", None) is not None:
        names["footsteps"] = True
        names["ZMP / DCM"] = True
    return names


def _rgb(color: int) -> tuple[int, int, int]:
    return (color >> 16) & 255, (color >> 8) & 255, color & 255


def _walker(run):
    return next((o.walker for o in getattr(run, "observers", ()) if hasattr(o, "walker")), None)


def overlay_data(run, t: float) -> dict:
    """The run's overlays now (module docstring), at simulated time ``t`` (s)."""
    out: dict = {}
    stack = run.stack
    for task in stack:
        if isinstance(task, CollisionAvoidance) and task.last is not None:
            rows, order = task.last
            sel = np.asarray(order[:WITNESSES], dtype=int)
            segs = np.stack([rows.p1[sel], rows.p2[sel]], axis=1) if len(sel) else np.zeros((0, 2, 3))
            colors = [_rgb(witness_color(float(rows.d[i]), task.safety, task.influence)) for i in sel]
            out["collision pairs"] = {"segments": segs, "colors": np.array(colors, np.uint8).reshape(-1, 3)}
    forces = [t_ for t_ in stack if isinstance(t_, Force) and t_.contact in stack]
    if forces:
        arrows, colors = [], []
        for task in forces:
            point, desired, measured = task_forces(run.robot, run.robot.data, task, stack)
            for f, color in ((desired, DESIRED), (measured, MEASURED)):
                if f is not None and np.linalg.norm(f) > 1e-3:
                    arrows.append((point, point + f / TASK_FORCE_SCALE * 1e-2))
                    colors.append(color)
        out["force task λ"] = {"arrows": np.array(arrows).reshape(-1, 2, 3),
                              "colors": np.array(colors, np.uint8).reshape(-1, 3)}
    w = _walker(run)
    if w is not None and w.plan is not None:
        out["footsteps"] = _footsteps(w)
        out["ZMP / DCM"] = _zmp_dcm(w, run.sim, t)
    return out


def _footsteps(w) -> dict:
    segs, colors = [], []
    a, b = STEP_CROSS
    for k, step in enumerate(w.plan.steps):
        c, s = np.cos(step.yaw), np.sin(step.yaw)
        p = np.array([step.x, step.y, w.ground_z + 0.003])
        along, across = np.array([c, s, 0.0]), np.array([-s, c, 0.0])
        segs += [(p - a * along, p + a * along), (p - b * across, p + b * across)]
        colors += [TAKEN if k < w.i else SIDE_COLORS.get(step.side, TAKEN)] * 2
    return {"segments": np.array(segs).reshape(-1, 2, 3), "colors": np.array(colors, np.uint8).reshape(-1, 3)}


def _zmp_dcm(w, sim, t: float) -> dict:
    z = w.ground_z + 0.004
    pts, colors = [], []
    if w.preview is not None:
        for xy, color in ((w.preview.zmp(t), ZMP), (w.preview.dcm(t), DCM)):
            pts.append((xy[0], xy[1], z))
            colors.append(color)
    f = np.asarray(sim.point_forces)
    fz = f[:, 2] if len(f) else np.zeros(0)
    if fz.sum() > 1e-3:
        cop = (np.asarray(sim.point_positions())[:, :2] * fz[:, None]).sum(axis=0) / fz.sum()
        pts.append((cop[0], cop[1], z))
        colors.append(COP)
    return {"points": np.array(pts).reshape(-1, 3), "colors": np.array(colors, np.uint8).reshape(-1, 3)}
