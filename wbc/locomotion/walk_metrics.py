"""A walk's figures, from the simulator's true state and contact forces (the metrics JSON's
``walk`` entry).

- ``steps_taken``: touch-downs made (``early``, ``late``: how many of them were; ``delay``,
  s: how long the plan waited for late landings in all).
- ``distance`` (m): the pelvis's travel from start to end along the plan (its displacement
  projected on the plan's, or its length when the plan goes nowhere).
- ``final_error`` (m), ``final_yaw_error`` (rad): the pelvis's horizontal position and yaw at
  the end against the plan's final pose (the start's pelvis carried by the feet's final
  mid-point and mean yaw).
- ``average_speed`` (m/s): ``distance`` over the time from the first lift-off to the last
  touch-down.
- ``stance_slip_max`` (m): the largest horizontal slide of a foot's contact points during one
  of its stances (from its force ramp's end at touch-down to its release).
- ``zmp_outside_cycles``: cycles whose ZMP, p = Σ f_z,i r_i / Σ f_z,i over every simulated
  contact point (flat ground), lies outside the convex hull of the points of the feet in
  contact in the controller's stack (``zmp_margin_min``, m: its least signed distance inside),
  over the cycles in which the ground carries more than a tenth of the weight.
- ``replan_time`` (s): median and max of the preview's replans (wall time).
- ``stopped``: None, or why the walk stopped the run (a fall, a missed touch-down).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from wbc.locomotion.footsteps import wrap


def _yaw(quat_xyzw: np.ndarray) -> float:
    x, y, z, w = quat_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _hull(points: np.ndarray) -> ConvexHull | None:
    if len(points) < 3:
        return None
    try:
        return ConvexHull(points)
    except QhullError:
        return None


def polygon_margin(vertices: np.ndarray, p: np.ndarray) -> float:
    """Signed distance (m) of ``p`` to the boundary of the convex polygon ``vertices`` ((k, 2),
    counter-clockwise; > 0 inside): min over the edges e_i = v_{i+1} − v_i of
    cross(e_i, p − v_i)/‖e_i‖; −∞ with fewer than 3 vertices."""
    if len(vertices) < 3:
        return -np.inf
    e = np.roll(vertices, -1, axis=0) - vertices
    d = p - vertices
    n = np.hypot(e[:, 0], e[:, 1])
    ok = n > 1e-12
    if ok.sum() < 3:
        return -np.inf
    return float(((e[ok, 0] * d[ok, 1] - e[ok, 1] * d[ok, 0]) / n[ok]).min())


def hull_margin(points: np.ndarray, p: np.ndarray) -> float:
    """Signed distance (m) of ``p`` to the boundary of the convex hull of ``points`` (xy;
    > 0 inside); −∞ with fewer than 3 points or a flat hull."""
    hull = _hull(points)
    return -np.inf if hull is None else polygon_margin(points[hull.vertices], p)


class WalkMetrics:
    """The figures of the module docstring for ``walker``'s walk; ``pts``: side -> indices of
    the foot's simulated contact points."""

    def __init__(self, walker, pts: dict[str, np.ndarray], dt: float) -> None:
        self.walker, self.pts, self.dt = walker, pts, dt
        self.anchor: dict[str, np.ndarray | None] = {s: None for s in pts}
        self.slip_max = 0.0
        self.zmp_outside = 0
        self.zmp_margin_min = np.inf
        self.pelvis0: np.ndarray | None = None
        self.pelvis = np.zeros(3)
        self.t = 0.0
        #: the last cycle's ZMP from the simulator's forces (xy, m; None: the ground carries
        #: under a tenth of the weight) and the support polygon, the convex hull of the feet in
        #: contact (its vertices in order, (k, 2) world xy, m; empty when there is none)
        self.zmp: np.ndarray | None = None
        self.support = np.zeros((0, 2))
        self.weight = walker.robot.weight          # N
        self._hull_key: tuple[str, ...] = ()
        self._hull_idx = np.zeros(0, dtype=int)

    def record(self, t: float, sim, stack) -> None:
        """After the simulator's step at ``t`` s (its true state and contact forces)."""
        w = self.walker
        q = sim.q
        self.t = t
        pose = np.array([q[0], q[1], _yaw(q[3:7])])
        if self.pelvis0 is None:
            self.pelvis0 = pose.copy()
        self.pelvis = pose
        pts = sim.point_positions()
        pf = sim.point_forces
        stance, stance_sides = [], []
        for side, idx in self.pts.items():
            task = w.contact_task[side]
            held = task.name in stack
            if held or float(pf[idx, 2].sum()) > w.spec.touchdown_force * self.weight:
                stance.append(idx)
                stance_sides.append(side)
            if held and task.fmax == np.inf:
                xy = pts[idx, :2]
                if self.anchor[side] is None:
                    self.anchor[side] = xy.copy()
                else:
                    d = xy - self.anchor[side]
                    s = float(np.sqrt((d * d).sum(axis=1)).max())
                    if s > self.slip_max:
                        self.slip_max = s
            else:
                self.anchor[side] = None
        fz = pf[:, 2]
        total = float(fz.sum())
        self.support = self._support(tuple(stance_sides), pts) if stance_sides else np.zeros((0, 2))
        self.zmp = None
        if stance and total > 0.1 * self.weight:
            self.zmp = zmp = (fz @ pts[:, :2]) / total
            margin = polygon_margin(self.support, zmp)
            self.zmp_margin_min = min(self.zmp_margin_min, margin)
            if margin < 0.0:
                self.zmp_outside += 1

    def _support(self, sides: tuple[str, ...], pts: np.ndarray) -> np.ndarray:
        """The support polygon of the feet ``sides`` at the points' positions ``pts``: its
        vertices (counter-clockwise, xy). The hull (qhull) is computed when the set of feet in
        contact changes; its vertex indices are kept, and read at the points' current positions."""
        if sides != self._hull_key:
            idx = np.concatenate([self.pts[s] for s in sides])
            hull = _hull(pts[idx, :2])
            self._hull_key = sides
            self._hull_idx = idx[hull.vertices] if hull is not None else idx
        return pts[self._hull_idx, :2]

    def summary(self, stopped: str | None) -> dict:
        w = self.walker
        out: dict = {"steps_taken": len(w.touchdowns),
                     "steps_planned": len(w.plan.steps) if w.plan is not None else 0,
                     "early": sum(td["early"] for td in w.touchdowns),
                     "late": sum(td["late"] for td in w.touchdowns),
                     "delay": w.delay,
                     "stance_slip_max": self.slip_max, "zmp_outside_cycles": self.zmp_outside,
                     "zmp_margin_min": float(self.zmp_margin_min) if np.isfinite(self.zmp_margin_min) else None,
                     "stopped": stopped, "warnings": list(w.warnings)}
        if w.plan is None or self.pelvis0 is None:
            return out
        start, final = w.start_feet, w.plan.final_feet()
        mid0 = (start["left"].xy + start["right"].xy) / 2
        mid1 = (final["left"].xy + final["right"].xy) / 2
        yaw0 = wrap(start["left"].yaw + 0.5 * wrap(start["right"].yaw - start["left"].yaw))
        yaw1 = wrap(final["left"].yaw + 0.5 * wrap(final["right"].yaw - final["left"].yaw))
        turn = wrap(yaw1 - yaw0)
        c, s = math.cos(turn), math.sin(turn)
        off = self.pelvis0[:2] - mid0
        goal = mid1 + np.array([c * off[0] - s * off[1], s * off[0] + c * off[1]])
        goal_yaw = wrap(self.pelvis0[2] + turn)
        moved = self.pelvis[:2] - self.pelvis0[:2]
        planned = goal - self.pelvis0[:2]
        n = float(np.linalg.norm(planned))
        distance = float(moved @ planned / n) if n > 1e-2 else float(np.linalg.norm(moved))
        out.update(distance=distance, final_error=float(np.linalg.norm(self.pelvis[:2] - goal)),
                   final_yaw_error=abs(wrap(self.pelvis[2] - goal_yaw)))
        if w.touchdowns and w.plan.single:
            walked = w.touchdowns[-1]["time"] - w.plan.single[0][0]
            out["average_speed"] = distance / walked if walked > 0 else None
        times = np.asarray(w.preview.replan_times) if w.preview is not None else np.zeros(0)
        if len(times):
            out["replan_time"] = {"median": float(np.median(times)), "max": float(np.max(times)), "count": len(times)}
        return out
