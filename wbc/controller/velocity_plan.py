"""The velocity cycle's rows, planned once per stack structure (:mod:`wbc.controller.velocity`).

What a velocity cycle does with the tasks' rows, decided once while the stack's structure
holds (its version, the levels solved, each task's weight and row count): a
:class:`~wbc.problem.buffer.RowBuffer` sized from a first call of every task's velocity rows,
then, per task, a writer (:func:`wbc.tasks.velocity.velocity_writer`) bound to that task's
blocks of the buffer, and the :class:`~wbc.problem.problem.Problem` the solver is handed
every cycle (the same object: its levels and stacked rows are views of the buffer). A cycle
is then: the writers' rows in place, those of the point frames, contacts, CoM, posture and
joint limits in one compiled call (:mod:`wbc.tasks.velocity_stack`), the others a compiled
pass each (rows constant in the state were written at planning), the rows of a task of
weight w ≠ 1 scaled by √w into its
block, nothing allocated, no list or dict built. A writer that finds its task's rows
changed shape (a contact made sliding) says so and the plan is rebuilt. Where the one call
covers every task and the solver is the hierarchical QP, the cycle's rows and its equality-only
step are a single compiled call (:meth:`VelocityPlan.fill_step`, :mod:`wbc.controller.velocity_step`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from wbc.problem.buffer import RowBuffer
from wbc.problem.problem import Problem
from wbc.problem.rows import Layout, Rows
from wbc.tasks.base import TASK_CHANGES
from wbc.tasks.collision_avoidance import CollisionAvoidance
from wbc.tasks.velocity import velocity_writer
from wbc.tasks.velocity_stack import stack_writer

from .velocity_step import ROWS_LEFT, call_table, rows_and_step, step_tables

_NO_INDEX = np.zeros(0, dtype=np.int64)


class VelocityPlan:
    """One stack structure's row buffer, writers and Problem (module docstring).

    Args:
        groups: the levels of tasks solved (the stack's, the differential drive in level 0).
        key: what identifies the structure besides the tasks' weights (the stack's version and
            the levels' sizes).
        robot: the robot, updated to this cycle's q (the rows of this first call are kept).
        dt: the control period (s).
        gain: K (1/s) of every motion task; None: √K_p of each task's own gains.
        margin: the QP margin (m/s, rad/s) of the Problem.
    """

    def __init__(self, groups: Sequence[Sequence], key: tuple, robot, dt: float, gain: float | None, margin: float) -> None:
        nv = robot.nv
        self.key = key
        self.groups = groups
        self.weights = [t.weight for tasks in groups for t in tasks]
        #: TASK_CHANGES[0] when :meth:`matches` last found these weights
        self._weights_seen = -1
        rows = []             # a first call of every task's rows, in arrays of their own: the structure
        for tasks in groups:
            rs = []
            for t in tasks:
                write, r = velocity_writer(t, robot, nv, dt, gain)
                write()
                rs.append(r)
            rows.append(rs)
        buf = self.buffer = RowBuffer(nv, groups, rows, key=key)
        buf.fill(groups, rows)
        self.writers = []
        #: (task, its inequality block of the buffer) of the collision-avoidance tasks: the
        #: velocity cycle's check of its command writes re-linearised rows there
        self.collision_rows: list[tuple[CollisionAvoidance, Rows]] = []
        #: (the task's scratch A, b, its block A, b, √w) of the tasks of weight w ≠ 1
        self.scaled: list[tuple] = []
        for tasks, plan, slots in zip(groups, buf.plans, buf.slots):
            for t, (_, eqv, inv, boxv), slot in zip(tasks, plan, slots):
                out = Rows(A=None if slot is None else slot.A, b=None if slot is None else slot.b,
                           C=None if inv is None else inv[0], lo=None if inv is None else inv[1],
                           hi=None if inv is None else inv[2],
                           box=None if boxv is None else (boxv[3], boxv[0], boxv[1]))
                write, _ = velocity_writer(t, robot, nv, dt, gain, out)
                self.writers.append(write)
                if isinstance(t, CollisionAvoidance):
                    self.collision_rows.append((t, out))
                if slot is not None and eqv[2] != 1.0:
                    self.scaled.append((slot.A, slot.b, eqv[0], eqv[1], eqv[2]))
        #: the covered tasks' rows in one compiled call (wbc.tasks.velocity_stack), and the writers
        #: it does not cover; None: every writer, one call each
        self.stack_write, self.rest = stack_writer(self.writers, [t for tasks in groups for t in tasks], buf, robot)
        self.levels = buf.levels
        #: q̇ dt of the last cycle the rows and the step were one call (fill_step), nv
        self.step = np.zeros(nv)
        #: x₀ of the one call's cascade (zeros: the plan's problem has no x_ref), read only
        self._x0 = np.zeros(nv)
        #: (the solver's planned tuple, its hints, sx, sf, the call's table, the support as bytes) of fill_step's call
        #: (velocity_step.step_tables, velocity_step.call_table)
        self._tables: tuple | None = None
        #: (prepare's answer, dt) last written into the tables' sf
        self._scalars: tuple | None = None
        self._dt = 0.0
        self.problem = Problem(buf.levels, Layout(nv=nv), np.eye(nv), np.zeros(nv), _NO_INDEX, margin=margin,
                               rows=buf.stacked)
        self.fill()

    def matches(self, groups: Sequence[Sequence], key: tuple) -> bool:
        """Whether this plan is still the stack's: the same structure key and task weights (these
        compared again only after a task's watched attribute was assigned:
        :data:`wbc.tasks.base.TASK_CHANGES`)."""
        if key != self.key:
            return False
        count = TASK_CHANGES[0]
        if count == self._weights_seen:
            return True
        i = 0
        weights = self.weights
        for tasks in groups:
            for t in tasks:
                if t.weight != weights[i]:
                    return False
                i += 1
        self._weights_seen = count
        return True

    def fill(self) -> bool:
        """Write this cycle's rows into the buffer (the robot updated to this cycle's q);
        False (nothing written to trust) when a task's rows changed shape: plan again. The
        covered tasks in one call, the others by their writers; every writer when the call
        leaves the cycle to them (a target not set yet, a logarithm near a half turn)."""
        fused = self.stack_write
        written = None if fused is None else fused()
        if written is False:
            return False
        for write in self.writers if written is None else self.rest:
            if not write():
                return False
        for sA, sb, A, b, w in self.scaled:
            np.multiply(sA, w, out=A)
            np.multiply(sb, w, out=b)
        return True

    def fill_step(self, solver, dt: float) -> tuple | Literal[False] | None:
        """:meth:`fill` and, where the one-call writer covers every task (no other writer: no
        weighted, collision or drive task), the problem starts from x₀ = 0 (no ``x_ref``) and
        ``solver`` offers the equality-only cascade (``equality_step``, ``equality_planned``: the
        hierarchical QP), that cascade in the same compiled call
        (:func:`wbc.controller.velocity_step.rows_and_step`, the solver's arrays held by address in
        tables built again when its planned rows or hints are other objects). Returns False (plan
        again) or None (the rows written, nothing solved: the caller's solve) as :meth:`fill`
        does, else ``rows_and_step``'s (code, nf, ni, X), with :attr:`step`
        ← q̇ dt (s) for code ACCEPTED.

        Args:
            solver: the controller's solver.
            dt: the control period (s).
        """
        fused = self.stack_write
        planned = None
        if fused is not None and not self.rest and self.problem.x_ref is None \
                and getattr(solver, "equality_step", None) is not None:
            entry = getattr(solver, "equality_planned", None)
            planned = None if entry is None else entry(self.problem)
        if fused is None or planned is None:
            return None if self.fill() else False
        tables = self._tables
        if tables is None or tables[0] is not planned[0] or tables[1] is not planned[1]:
            got = planned[0]
            sx, sf = step_tables((got[3], got[4], got[5]), planned[1], self._x0, self.step)
            tables = self._tables = (got, planned[1], sx, sf, *call_table(fused.held, sx, sf))
            self._scalars = None
        args = fused.prepare()
        if args is None or args is False:       # this cycle by the writers, or plan again
            return None if args is None and all(write() for write in self.writers) else False
        post_e, margin, k = args
        if args is not self._scalars or dt != self._dt:      # sf's margin, k, dt: written when prepare's answer is new
            sf = tables[3]
            sf[0], sf[1], sf[2] = margin, k, dt
            self._scalars, self._dt = args, dt
        out = rows_and_step(tables[4], fused.robot.q, post_e)
        if out[0] == ROWS_LEFT:                 # this cycle by the writers
            return None if all(write() for write in self.writers) else False
        return out
