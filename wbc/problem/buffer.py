"""The stack's rows in five arrays, and the levels as views of them (boundary data).

What a solver reads of a stack: the :class:`~wbc.problem.rows.Level` views and the five
arrays themselves (:class:`~wbc.problem.rows.StackedRows`, ``Problem.rows``), which a
compiled solver run reads in one pass. The tasks write their equality rows straight into
them: :meth:`RowBuffer.slots` hands each task its :class:`~wbc.problem.rows.RowSlot` for
one call of ``Task.rows``.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import count
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from .rows import Level, RowBlock, Rows, RowSlot, StackedRows

if TYPE_CHECKING:
    from ..tasks.base import Task

#: serial number of each buffer built (part of ``StackedRows.structure``)
_BUILDS = count()


class RowBuffer:
    """Every level's rows in five stack-wide arrays: A, b (equalities, each task's rows
    scaled by √weight) and C, l, u (inequalities; per level the tasks' general rows, then
    the box bounds as unit rows, set once). Each level is a block of rows, and its Level
    holds views of that block, so the solvers see levels while one product per array
    evaluates every level's rows (:func:`row_values`). Built for one structure (tasks, their
    row counts, weights and box indices); :meth:`fill` refuses another.

    Each task with equality rows has a :class:`RowSlot` (:attr:`slots`): for a task of
    weight 1 its block of A and b, so that its rows are written in place and nothing is
    copied; for another weight the buffer's scratch, scaled by √weight into the block."""

    def __init__(self, nx: int, groups: Sequence[Sequence[Task]], rows: list[list[Rows]], first_index: int = 0,
                 key=None) -> None:
        self.nx, self.key = nx, key
        ne = sum(r.n_eq for rs in rows for r in rs)
        ni = sum(r.n_in for rs in rows for r in rs)
        self.A, self.b = np.zeros((ne, nx)), np.zeros(ne)
        self.C, self.lo, self.hi = np.zeros((ni, nx)), np.zeros(ni), np.zeros(ni)
        self.plans: list[list[tuple]] = []
        self.levels: list[Level] = []
        self.spans: list[tuple[int, int, int, int, int]] = []
        #: per level, per task: where it writes its equality rows (None: it has none)
        self.slots: list[list[RowSlot | None]] = []
        e = i = 0
        for k, (tasks, rs) in enumerate(zip(groups, rows)):
            e0, i0 = e, i
            ng = sum(r.C.shape[0] for r in rs if r.C is not None)
            g, bx = i0, i0 + ng
            eq_slices, in_slices, plan, box_idx, blocks, slots = {}, {}, [], [], [], []
            for t, r in zip(tasks, rs):
                eqv = inv = boxv = slot = None
                if r.A is not None:
                    m = r.A.shape[0]
                    eq_slices[t.name] = slice(e - e0, e - e0 + m)
                    blocks.append(RowBlock(t.name, eq_slices[t.name], t.on_forces, t.regularizer, t.layout_only_A,
                                           t.equation_of_motion))
                    eqv = (self.A[e:e + m], self.b[e:e + m], float(np.sqrt(t.weight)))
                    slot = RowSlot(eqv[0], eqv[1]) if eqv[2] == 1.0 else RowSlot(np.zeros((m, nx)), np.zeros(m))
                    e += m
                if r.C is not None and r.C.shape[0]:
                    m = r.C.shape[0]
                    in_slices[t.name] = slice(g - i0, g - i0 + m)
                    inv = (self.C[g:g + m], self.lo[g:g + m], self.hi[g:g + m])
                    g += m
                if r.box is not None:
                    idx = np.asarray(r.box[0], dtype=int)
                    m = len(idx)
                    self.C[bx + np.arange(m), idx] = 1.0
                    boxv = (self.lo[bx:bx + m], self.hi[bx:bx + m], r.box[0], idx.copy())
                    box_idx.append(idx)
                    bx += m
                plan.append((t.weight, eqv, inv, boxv))
                slots.append(slot)
            i = bx
            box = None
            if box_idx:
                box = (np.concatenate(box_idx), self.lo[i0 + ng:i], self.hi[i0 + ng:i])
            lvl = Level(index=first_index + k, names=[t.name for t in tasks], A=self.A[e0:e], b=self.b[e0:e],
                        C=self.C[i0:i0 + ng], lo=self.lo[i0:i0 + ng], hi=self.hi[i0:i0 + ng], box=box,
                        eq_slices=eq_slices, in_slices=in_slices, blocks=blocks,
                        regularizers_only=bool(tasks) and all(t.regularizer for t in tasks),
                        kinds=[t.kind for t in tasks],
                        regularizers=frozenset(t.name for t in tasks if t.regularizer),
                        ineq=(self.C[i0:i], self.lo[i0:i], self.hi[i0:i]))
            self.plans.append(plan)
            self.levels.append(lvl)
            self.spans.append((e0, e, i0, ng, i))
            self.slots.append(slots)
        #: where each level's equality and inequality rows end in (A, b) and (C, lo, hi)
        self.eq_end = np.array([sp[1] for sp in self.spans], dtype=np.int64)
        self.ineq_end = np.array([sp[4] for sp in self.spans], dtype=np.int64)
        #: the five arrays as the problem hands them to the solvers
        self.stacked = StackedRows(self.A, self.b, self.C, self.lo, self.hi, self.eq_end, self.ineq_end,
                                   self.spans, (key, next(_BUILDS)))

    def fill(self, groups: Sequence[Sequence[Task]], rows: list[list[Rows]]) -> bool:
        """Copy this cycle's rows in (those written into a slot of A, b are there already);
        False (nothing to trust) if they no longer have the structure the buffer was built for."""
        if len(rows) != len(self.plans):
            return False
        put = _put
        for plan, rs, tasks in zip(self.plans, rows, groups):
            if len(rs) != len(plan):
                return False
            for entry, r, t in zip(plan, rs, tasks):
                if not put(entry, r, t):
                    return False
        return True

    def refill(self, robot, layout, groups: Sequence[Sequence[Task]],
               called: dict[tuple[int, int], Rows] | None = None) -> list[list[Rows]] | None:
        """Each task's rows of this cycle (``Task.rows`` with its slot) put in as it comes,
        one pass over the tasks (:meth:`fill`'s checks and copies, task by task): None when
        every task's rows are in; else (the structure is no longer the buffer's) every task's
        :class:`Rows` of this call, each task called once, for a new buffer.

        Args:
            robot: the :class:`~wbc.robot.model.RobotModel`, updated to this cycle's state.
            layout: this cycle's :class:`~wbc.problem.rows.Layout`.
            groups: the tasks, level by level (as the buffer was built for).
            called: rows of this cycle already called, by (level, place): used, not called
                again (a task's ``rows`` is called once a cycle); default none.
        """
        plans, all_slots, put = self.plans, self.slots, _put
        done = called or {}
        ok = len(groups) == len(plans)
        rows: list[list[Rows]] = []
        for k, tasks in enumerate(groups):
            level: list[Rows] = []
            rows.append(level)
            if ok and len(tasks) == len(plans[k]):
                for j, (t, entry, out) in enumerate(zip(tasks, plans[k], all_slots[k])):
                    r = done[(k, j)] if (k, j) in done else t.rows(robot, layout, out)
                    level.append(r)
                    if not put(entry, r, t):
                        ok = False
                        break
                else:
                    continue
            ok = False
            # the structure changed: the level's other tasks called once each, in their slots
            slots = all_slots[k] if k < len(all_slots) else []
            for j in range(len(level), len(tasks)):
                level.append(done[(k, j)] if (k, j) in done else
                             tasks[j].rows(robot, layout, slots[j] if j < len(slots) else None))
        return None if ok else rows


def _put(entry: tuple, r: Rows, t: Task) -> bool:
    """One task's rows ``r`` into its place in the buffer (``entry``, its plan: weight,
    equality, inequality and box views); False if they do not have the structure it was
    built for (another weight, shape or box index)."""
    if t.weight != entry[0]:
        return False
    rA, rb = r.A, r.b
    eqv = entry[1]
    if rA is not None:
        if eqv is None or rb is None:
            return False
        A, b, w = eqv
        if rA is A and rb is b:
            pass                        # written in place, in its slot
        elif rA.shape != A.shape:
            return False
        elif w == 1.0:
            np.copyto(A, rA)
            np.copyto(b, rb)
        else:
            np.multiply(rA, w, out=A)
            np.multiply(rb, w, out=b)
    elif eqv is not None:
        return False
    rC = r.C
    inv = entry[2]
    if rC is not None and len(rC):
        rlo, rhi = r.lo, r.hi
        if inv is None or rC.shape != inv[0].shape or rlo is None or rhi is None:
            return False
        C, lo, hi = inv
        np.copyto(C, rC)
        np.copyto(lo, rlo)
        np.copyto(hi, rhi)
    elif inv is not None:
        return False
    rbox = r.box
    boxv = entry[3]
    if rbox is not None:
        if boxv is None:
            return False
        lo, hi, src, idx = boxv
        if rbox[0] is not src and not np.array_equal(rbox[0], idx):
            return False
        np.copyto(lo, rbox[1])
        np.copyto(hi, rbox[2])
    elif boxv is not None:
        return False
    return True


def split_values(values: np.ndarray, ne: int, ni: int) -> tuple[np.ndarray, ...]:
    """(A x − b, C x, l, u, b) as views of :func:`row_values`' array (ne equality rows, ni
    inequality rows; level k's rows are ``RowBuffer.spans[k]`` of each)."""
    return (values[:ne], values[ne:ne + ni], values[ne + ni:ne + 2 * ni], values[ne + 2 * ni:ne + 3 * ni],
            values[ne + 3 * ni:])


@nb.njit(cache=True)
def row_values(A, b, C, lo, hi, x):
    """[A x − b, C x, l, u, b] over a :class:`RowBuffer`'s arrays in one new array (one
    allocation, one compiled pass): the rows' values a cycle keeps for its diagnostics,
    the buffer being refilled next cycle."""
    ne, ni = b.shape[0], lo.shape[0]
    out = np.empty(2 * ne + 3 * ni)
    if ne:      # A x by the same product as ``A @ x``, written in place (no temporary), then − b
        np.dot(A, x, out[:ne])
        out[:ne] -= b
    if ni:
        np.dot(C, x, out[ne:ne + ni])
    out[ne + ni:ne + 2 * ni] = lo
    out[ne + 2 * ni:ne + 3 * ni] = hi
    out[ne + 3 * ni:] = b
    return out
