"""The walker in the run loop: a :class:`~wbc.runner.observers.RunObserver` that runs the
:class:`~wbc.locomotion.walker.Walker` before each solve, reads the feet's normal forces from
the simulator (the feet's force sensors), and measures the walk
(:class:`~wbc.locomotion.walk_metrics.WalkMetrics`) after each step; its summary is the
metrics' ``walk`` entry. A missed touch-down or a fall stops the run (``stop_reason``).

What a view or a plot reads, plain arrays in the world frame (xy, m), after each step
(:meth:`WalkObserver.after_step`): ``com``, ``com_ref`` (the CoM task's reference), ``dcm``
(ξ = c + ċ/ω, measured), ``dcm_ref`` (of the reference), ``zmp`` (from the simulator's
contact forces; None when the ground carries under a tenth of the weight), ``zmp_ref`` (the
plan's ZMP reference), ``support`` ((k, 2), the convex hull of the points of the feet in
contact, in order); :meth:`WalkObserver.footsteps` (the plan's footsteps and their state),
``soles`` (side -> the sole's half length and half width, m). With ``series=True`` the run's
metrics carry them per cycle under ``series.walk`` (:meth:`WalkObserver.series`), for
``wbc run --plot`` (:mod:`wbc.runner.walk_plot`).
"""

from __future__ import annotations

import numpy as np

from wbc.locomotion.walk_metrics import WalkMetrics
from wbc.locomotion.walker import SIDES, Walker, WalkSpec
from wbc.runner.metrics import fallen
from wbc.runner.observers import Cycle, RunObserver

#: the per-cycle quantities of ``series.walk`` (each (n, 2), xy, m; NaN where undefined)
TRACED = ("com", "com_ref", "dcm", "dcm_ref", "zmp", "zmp_ref")


class WalkObserver(RunObserver):
    """The walk of ``spec`` in a run of ``robot``/``stack`` under ``ctrl`` on ``sim``;
    ``series``: record the module docstring's quantities every cycle."""

    def __init__(self, spec: WalkSpec, robot, stack, ctrl, sim, dt: float, series: bool = False) -> None:
        self.walker = Walker(spec, robot, stack, ctrl, dt)
        m = robot.model
        self.pts = {}
        for side in SIDES:
            jid = m.frames[self.walker.sole_fid[side]].parentJoint
            self.pts[side] = np.array([i for i, (j, _) in enumerate(sim.points) if j == jid], dtype=int)
        self.fz = {side: 0.0 for side in SIDES}
        self.metrics = WalkMetrics(self.walker, self.pts, dt)
        self.base_z0 = float(sim.q[2]) if robot.root == "free_flyer" else None
        self.stop_reason: str | None = None
        surf = {side: robot.contact(spec.contacts[side]) for side in SIDES}
        self.soles = {side: (float(s.half_length), float(s.half_width)) for side, s in surf.items()}
        self.com = np.full(2, np.nan)
        self.com_ref = np.full(2, np.nan)
        self.dcm = np.full(2, np.nan)
        self.dcm_ref = np.full(2, np.nan)
        self.zmp: np.ndarray | None = None
        self.zmp_ref = np.full(2, np.nan)
        self.support = np.zeros((0, 2))
        self.lifts: list[dict] = []          # each swing's start: {time, side}
        self._state = "wait"
        self._trace: dict[str, list] | None = {k: [] for k in ("t", *TRACED)} if series else None
        self._zmp1 = np.zeros((1, 2))

    def after_events(self, c: Cycle) -> None:
        if c.k == 0:        # the feet's contacts switch during the run: the run's metrics leave them out
            for t in self.walker.contact_task.values():
                c.switched.add(t.name)          # type: ignore[union-attr]  # the run's own set

    def before_solve(self, c: Cycle) -> None:
        pf = c.sim.point_forces
        for side in SIDES:
            self.fz[side] = float(pf[self.pts[side], 2].sum())
        w = self.walker
        w.update(c.t, c.q, c.v, self.fz, None if c.last_sol is None else c.last_sol.qdd)
        if w.stopped:
            self.stop_reason = w.stopped
        if w.state == "swing" and self._state != "swing" and w.plan is not None:
            self.lifts.append({"time": c.t, "side": w.plan.steps[w.i].side})
        self._state = w.state

    def after_step(self, c: Cycle) -> None:
        t = c.t + c.sim.dt if hasattr(c.sim, "dt") else c.t
        self.metrics.record(t, c.sim, c.stack)
        if self.base_z0 is not None and fallen(c.sim.q, self.base_z0):
            self.stop_reason = self.stop_reason or "fell"
        self._update_view(c.t)

    def _update_view(self, t: float) -> None:
        """The view's quantities of this cycle (the module docstring), and its trace."""
        w = self.walker
        if w.preview is None or w.plan is None:
            return
        omega = w.preview.omega
        robot = w.robot                 # the controller's model data, updated by this cycle's solve
        self.com = robot.com[:2].copy()
        self.dcm = self.com + robot.com_velocity[:2] / omega
        task = w.com_task
        assert task.target is not None, "the walker sets the CoM reference every cycle"
        self.com_ref = task.target[:2].copy()
        self.dcm_ref = self.com_ref + task.target_velocity[:2] / omega
        self.zmp_ref = w.plan.table.sample(t - w.delay - w.dt, w.dt, 1, self._zmp1)[0].copy()
        self.zmp = None if self.metrics.zmp is None else self.metrics.zmp.copy()
        self.support = self.metrics.support
        tr = self._trace
        if tr is not None:
            tr["t"].append(t)
            for k in TRACED:
                v = getattr(self, k)
                tr[k].append((np.nan, np.nan) if v is None else (float(v[0]), float(v[1])))

    def footsteps(self) -> list[dict]:
        """The plan's footsteps, the start's feet first: {side, x, y, yaw (m, rad), lift, land
        (the single support's planned start and end, s; None for the start's), state}; state:
        ``"start"``, ``"down"`` (taken), ``"swing"`` (its foot in the air), ``"planned"``."""
        w = self.walker
        if w.plan is None:
            return []
        out = [{"side": f.side, "x": f.x, "y": f.y, "yaw": f.yaw, "lift": None, "land": None, "state": "start"}
               for f in w.plan.start.values()]
        for i, (s, (t0, t1)) in enumerate(zip(w.plan.steps, w.plan.single, strict=False)):
            delay = 0.0 if i < w.i else w.delay
            state = "down" if i < w.i else ("swing" if i == w.i and w.state in ("swing", "late") else "planned")
            out.append({"side": s.side, "x": s.x, "y": s.y, "yaw": s.yaw, "lift": t0 + delay, "land": t1 + delay,
                        "state": state})
        return out

    def series(self) -> dict:
        """``{"walk": ...}`` for the run's ``series`` (with ``series=True``): the per-cycle
        arrays of :data:`TRACED` with their times ``t``, the footsteps, the swings' actual
        lift-offs and touch-downs ({time, side}), the soles' half sizes."""
        if self._trace is None:
            return {}
        w = self.walker
        return {"walk": {**{k: [list(x) for x in v] if k != "t" else list(v) for k, v in self._trace.items()},
                         "footsteps": self.footsteps(), "lifts": list(self.lifts),
                         "touchdowns": [{"time": td["time"], "side": td["side"]} for td in w.touchdowns],
                         "soles": {s: list(v) for s, v in self.soles.items()}}}

    def summary(self) -> dict:
        return {"walk": self.metrics.summary(self.stop_reason)}
