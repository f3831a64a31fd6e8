"""The run metrics' task errors, cycle by cycle, in one compiled call (#26).

Per task that has an error (not a contact), each cycle: ‖e‖ = √(e·e) and, for a task that mixes
units (a pose: m and rad), ‖e_u‖ of each unit's components, accumulated as
:class:`~wbc.runner.stats.Running` does (n, Σx, Σx², min, max, max |x|, last), in the rows of one
table (:class:`~wbc.runner.stats.RunningRow`); a task removed by an event repeats its last value.

:func:`record_errors` does, for every task, what ``record_command`` did in numpy and Python, with
the same floating-point operations in the same order, so every figure keeps its bits:

- the error of a :class:`~wbc.tasks.CoM` task, target − CoM on its axes, and of a
  :class:`~wbc.tasks.Posture` task whose coordinates are all a vector space's (bounded revolute,
  prismatic: pinocchio's ``difference`` is the plain q_d − q there), computed in the call; any
  other task's ``error(robot)`` is written into the call's buffer before it;
- e·e by numba's ``np.dot``, the BLAS ``ddot`` numpy's ``e.dot(e)`` calls
  (``tests/runner/test_task_errors.py`` holds the two equal on random vectors);
- the running figures in Python's float operations (``Running.add``).

In the closed loop the former path cost ~30 µs a cycle on Talos (three tasks: a numpy ufunc, a
pinocchio call and a BLAS call each, every one cold after the solve and the step), ~4 µs of it
arithmetic.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.runner.state_kernel import ratio_max
from wbc.runner.stats import LAST, N, RunningRow, add_value
from wbc.tasks.com import CoM
from wbc.tasks.contact import Contact
from wbc.tasks.posture import Posture
from wbc.tasks.velocity_stack import _vector_space_coordinates

#: how a task's error is had: ``error(robot)`` written into the buffer, a CoM's, a posture's
GENERIC, COM, POSTURE = 0, 1, 2
#: a task's state in a cycle: removed (repeats its last value), live, recorded in Python this cycle
REMOVED, LIVE, DONE = 0, 1, 2
#: a task's columns in the spec: kind, buffer offset, length, stats row, first part, end of parts,
#: first index of its own (the CoM's axes, the posture's q indices)
_W = 7
_EMPTY = np.zeros(0)


@nb.njit(cache=True)
def record_errors(ints, stats, ebuf, q, com, com_target, q_ref, tau, inv_limit):
    """One cycle's task errors into the running figures (module docstring); returns the command's
    worst torque ratio, :func:`~wbc.runner.state_kernel.ratio_max` (``tau``, ``inv_limit``), in the same call.

    Args:
        ints: the layout (:class:`TaskErrors`): [number of tasks, of parts, spec offset, parts
            offset, part indices offset, states offset, own indices offset], then per task its
            :data:`_W` columns, per part (stats row, first index, end), the parts' indices into
            the task's error, each task's state (:data:`REMOVED`, :data:`LIVE`, :data:`DONE`), the
            CoM's axes and the posture's q indices.
        stats: the running figures, one row a task or part (:class:`~wbc.runner.stats.RunningRow`).
        ebuf: the errors, each task's at its offset (the generic tasks' written before the call).
        q: the controller's configuration (nq); ``q_ref`` the posture's target (nq; empty: none).
        com: the controller's CoM (3, m); ``com_target`` the CoM task's target (3; empty: none).
        tau, inv_limit: the torque sent (N·m) and 1/τ_max of its joints.
    """
    nt, so, po, io, lo = ints[0], ints[2], ints[3], ints[4], ints[5]
    for k in range(nt):
        c = so + _W * k
        kind, a, m, row, p0, p1, own = ints[c], ints[c + 1], ints[c + 2], ints[c + 3], ints[c + 4], \
            ints[c + 5], ints[c + 6]
        state = ints[lo + k]
        if state == DONE:
            continue
        if state == REMOVED:
            if stats[row, N] > 0:           # a task removed by an event keeps its last value
                add_value(stats, row, stats[row, LAST])
                for p in range(p0, p1):
                    r = ints[po + 3 * p]
                    add_value(stats, r, stats[r, LAST])
            continue
        e = ebuf[a:a + m]
        if kind == COM:
            for j in range(m):
                s = ints[own + j]
                e[j] = com_target[s] - com[s]
        elif kind == POSTURE:
            for j in range(m):
                s = ints[own + j]
                e[j] = q_ref[s] - q[s]
        add_value(stats, row, math.sqrt(np.dot(e, e)))
        for p in range(p0, p1):
            r, i0, i1 = ints[po + 3 * p], ints[po + 3 * p + 1], ints[po + 3 * p + 2]
            ei = np.empty(i1 - i0)
            for i in range(i1 - i0):
                ei[i] = e[ints[io + i0 + i]]
            add_value(stats, r, math.sqrt(np.dot(ei, ei)))
    return ratio_max(tau, inv_limit)


class TaskErrors:
    """The run's task-error figures (module docstring): built from the stack at the start, its
    :meth:`watch` at events, :meth:`record` each cycle.

    Attributes:
        errs: per task name its figures (:class:`~wbc.runner.stats.RunningRow`).
        tasks: (name, task) per task, in ``errs``' order.
        units: per task its error's unit ("m", "rad", "N", ...; "m+rad" for a pose).
        split: per task that mixes units, (unit, component indices) of each.
        parts: per such task, each unit's figures (:class:`~wbc.runner.stats.RunningRow`).
    """

    def __init__(self, robot, stack) -> None:
        self.robot = robot
        found = [(t.name, t, e) for t in stack if not isinstance(t, Contact) and (e := t.error(robot)) is not None]
        self.tasks = [(name, t) for name, t, _ in found]
        self.units: dict[str, str] = {}
        self.split: dict[str, list[tuple[str, np.ndarray]]] = {}
        rows: list[tuple[str, str | None]] = []
        for name, task, _ in found:
            units = task.error_units(robot)
            kinds = list(dict.fromkeys(units))
            self.units[name] = "+".join(kinds) if kinds else "unitless"
            rows.append((name, None))
            if len(kinds) > 1:
                self.split[name] = [(u, np.flatnonzero([x == u for x in units])) for u in kinds]
                rows += [(name, u) for u in kinds]
        self.stats = np.zeros((len(rows), 7))
        row_of = {key: r for r, key in enumerate(rows)}
        self.errs = {name: RunningRow(self.stats, row_of[name, None]) for name, _, _ in found}
        self.parts = {name: {u: RunningRow(self.stats, row_of[name, u]) for u, _ in s} for name, s in self.split.items()}
        self._build(found, row_of)

    def _build(self, found: list, row_of: dict) -> None:
        """The compiled call's layout (:func:`record_errors`' ``ints``) and buffer."""
        robot = self.robot
        spec: list[int] = []
        parts: list[tuple[int, int, int]] = []
        pidx: list[int] = []
        own: list[int] = []
        self.com = self.posture = None
        generic = []
        a = 0
        for k, (name, task, e) in enumerate(found):
            m = int(np.shape(e)[0])
            kind, idx = GENERIC, None
            if type(task) is CoM and self.com is None:
                kind, idx, self.com = COM, [int(s) for s in task._sel], task
            elif type(task) is Posture and self.posture is None:
                idx = _vector_space_coordinates(robot.model, np.asarray(task._indices(robot)))
                if idx is not None:
                    kind, self.posture = POSTURE, task
            if kind == GENERIC:
                generic.append((k, task, slice(a, a + m), m, name))
            p0 = len(parts)
            for u, ix in self.split.get(name, ()):
                parts.append((row_of[name, u], len(pidx), len(pidx) + len(ix)))
                pidx += [int(i) for i in ix]
            spec += [kind, a, m, row_of[name, None], p0, len(parts), len(own)]
            own += idx or []
            a += m
        head = 7
        so = head
        po = so + len(spec)
        io = po + 3 * len(parts)
        lo = io + len(pidx)
        oo = lo + len(found)
        spec = [v + oo if j % _W == 6 else v for j, v in enumerate(spec)]
        self.ints = np.array([len(found), len(parts), so, po, io, lo, oo] + spec
                             + [v for p in parts for v in p] + pidx + [REMOVED] * len(found) + own, dtype=np.int64)
        self.state = self.ints[lo:oo]
        self.ebuf = np.zeros(a)
        self.generic = [(k, task, self.ebuf[s], m, self.errs[name], self.parts.get(name)) for k, task, s, m, name in generic]
        self.live: list = []

    def watch(self, stack) -> None:
        """After events: the tasks still in ``stack`` are recorded, the others repeat their last value."""
        for k, (name, _) in enumerate(self.tasks):
            self.state[k] = LIVE if name in stack else REMOVED
        names = {name for name, _ in self.tasks if name in stack}
        self.live = [g for g in self.generic if self.tasks[g[0]][0] in names]

    def record(self, tau: np.ndarray, inv_limit: np.ndarray) -> float:
        """This cycle's errors on the controller's model (the robot's state as the solve left it);
        returns max(0, max_i |τ_i| · inv_limit_i) (:func:`~wbc.runner.state_kernel.ratio_max`).

        Args:
            tau: the torque sent (N·m).
            inv_limit: 1/τ_max of its joints.
        """
        robot, state = self.robot, self.state
        for k, task, view, m, row, parts in self.live:
            e = task.error(robot)
            if e.shape == (m,):
                view[:] = e
                state[k] = LIVE
            else:                           # an error of another length this cycle: recorded here
                state[k] = DONE
                row.add(math.sqrt(e.dot(e)))
                for u, idx in self._split_of(task):
                    ei = e[idx]
                    parts[u].add(math.sqrt(ei.dot(ei)))
        com, post = self.com, self.posture
        target: np.ndarray | None = _EMPTY
        if com is not None:
            target = com.target
            if target is None:              # its first error sets it (CoM.error's)
                com.error(robot)
                target = com.target
        q_ref = _EMPTY if post is None else post._q_ref(robot)
        return record_errors(self.ints, self.stats, self.ebuf, robot.q, robot.com, target, q_ref, tau, inv_limit)

    def _split_of(self, task) -> list:
        return self.split.get(task.name, [])

    def lasts(self) -> list[float]:
        """Each task's last value (``errs``' order)."""
        return [e.last for e in self.errs.values()]
