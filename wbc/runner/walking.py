"""The walker in the run loop: a :class:`~wbc.runner.observers.RunObserver` that runs the
:class:`~wbc.locomotion.walker.Walker` before each solve, reads the feet's normal forces from
the simulator (the feet's force sensors), and measures the walk
(:class:`~wbc.locomotion.walk_metrics.WalkMetrics`) after each step; its summary is the
metrics' ``walk`` entry. A missed touch-down or a fall stops the run (``stop_reason``)."""

from __future__ import annotations

import numpy as np

from wbc.locomotion.walk_metrics import WalkMetrics
from wbc.locomotion.walker import SIDES, Walker, WalkSpec
from wbc.runner.metrics import fallen
from wbc.runner.observers import Cycle, RunObserver


class WalkObserver(RunObserver):
    """The walk of ``spec`` in a run of ``robot``/``stack`` under ``ctrl`` on ``sim``."""

    def __init__(self, spec: WalkSpec, robot, stack, ctrl, sim, dt: float) -> None:
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

    def after_events(self, c: Cycle) -> None:
        if c.k == 0:        # the feet's contacts switch during the run: the run's metrics leave them out
            for t in self.walker.contact_task.values():
                c.switched.add(t.name)          # type: ignore[union-attr]  # the run's own set

    def before_solve(self, c: Cycle) -> None:
        pf = c.sim.point_forces
        for side in SIDES:
            self.fz[side] = float(pf[self.pts[side], 2].sum())
        w = self.walker
        w.update(c.t, c.q, c.v, self.fz)
        if w.stopped:
            self.stop_reason = w.stopped

    def after_step(self, c: Cycle) -> None:
        self.metrics.record(c.t + c.sim.dt if hasattr(c.sim, "dt") else c.t, c.sim, c.stack)
        if self.base_z0 is not None and fallen(c.sim.q, self.base_z0):
            self.stop_reason = self.stop_reason or "fell"

    def summary(self) -> dict:
        return {"walk": self.metrics.summary(self.stop_reason)}
