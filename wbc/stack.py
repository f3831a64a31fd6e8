"""Stack: the task hierarchy, ordered levels of weighted tasks (index 0 = highest).

Per cycle the stack turns its tasks into plain data for the solvers: a
:class:`~wbc.rows.Layout` (where each contact's force lives in x) and one
:class:`~wbc.rows.Level` per priority, with the rows of its tasks stacked and
each task's equality rows scaled by √weight, so a level minimises
Σ_i w_i ‖A_i x − b_i‖².
"""

from __future__ import annotations

from typing import Iterable, Iterator

import numpy as np

from .errors import StackError
from .rows import Layout, Level, Rows
from .tasks.base import Task
from .tasks.contact import Contact


class TaskGroup:
    """Operator sugar: ``(contacts + limits) / com / hands / posture`` builds a Stack."""

    def __init__(self, tasks: Iterable[Task]) -> None:
        self.tasks = list(tasks)

    def __add__(self, other) -> "TaskGroup":
        if isinstance(other, Task):
            return TaskGroup(self.tasks + [other])
        if isinstance(other, TaskGroup):
            return TaskGroup(self.tasks + other.tasks)
        return NotImplemented

    def __truediv__(self, other) -> "Stack":
        return Stack([self.tasks]) / other


def _as_level(obj) -> list[Task]:
    if isinstance(obj, Task):
        return [obj]
    if isinstance(obj, TaskGroup):
        return list(obj.tasks)
    try:
        tasks = list(obj)
    except TypeError:
        raise StackError(f"a stack level must be a task or a list of tasks, got {type(obj).__name__}") from None
    for t in tasks:
        if not isinstance(t, Task):
            raise StackError(f"a stack level must hold tasks, got {type(t).__name__}: {t!r}")
    return tasks


class Stack:
    """Ordered priority levels, each a list of tasks; tasks addressable by name."""

    def __init__(self, levels: Iterable = ()) -> None:
        self.levels: list[list[Task]] = []
        for lvl in levels:
            self.levels.append(_as_level(lvl))
        self._check_names()

    def _check_names(self) -> None:
        seen: dict[str, int] = {}
        for k, lvl in enumerate(self.levels):
            for t in lvl:
                if t.name in seen:
                    raise StackError(
                        f"two tasks are named '{t.name}' (levels {seen[t.name]} and {k}); names must be unique"
                    )
                seen[t.name] = k
        self.version = getattr(self, "version", 0) + 1

    # ------------------------------------------------------------- building
    def __truediv__(self, other) -> "Stack":
        return Stack(self.levels + [_as_level(other)])

    def __getitem__(self, name: str) -> Task:
        for lvl in self.levels:
            for t in lvl:
                if t.name == name:
                    return t
        raise KeyError(f"no task named '{name}' in the stack; tasks: {self.names()}")

    def __contains__(self, name: str) -> bool:
        return name in self.names()

    def __iter__(self) -> Iterator[Task]:
        for lvl in self.levels:
            yield from lvl

    def __len__(self) -> int:
        return len(self.levels)

    def names(self) -> list[str]:
        return [t.name for t in self]

    def level_of(self, name: str) -> int:
        for k, lvl in enumerate(self.levels):
            if any(t.name == name for t in lvl):
                return k
        raise KeyError(f"no task named '{name}' in the stack; tasks: {self.names()}")

    def add(self, task: Task, level: int) -> None:
        """Insert ``task`` in ``level`` (== len(stack) appends a new lowest level)."""
        if not 0 <= level <= len(self.levels):
            raise StackError(f"level must be in [0, {len(self.levels)}], got {level}")
        if level == len(self.levels):
            self.levels.append([])
        self.levels[level].append(task)
        try:
            self._check_names()
        except StackError:
            self.levels[level].pop()
            raise

    def remove(self, name: str) -> Task:
        """Remove the task named ``name`` (empty levels are dropped) and return it."""
        k = self.level_of(name)
        task = self[name]
        self.levels[k].remove(task)
        if not self.levels[k]:
            del self.levels[k]
        self._check_names()
        return task

    def move(self, name: str, level: int) -> None:
        """Re-prioritise a task."""
        task = self.remove(name)
        self.add(task, min(level, len(self.levels)))

    def contacts(self) -> list[Contact]:
        got = self.__dict__.get("_contacts")
        if got is None or got[0] != self.version:
            got = self._contacts = (self.version, [t for t in self if isinstance(t, Contact)])
        return list(got[1])

    def to_list(self) -> list[list[dict]]:
        """The stack as plain data: levels of ``{type: ..., <constructor arguments>}``."""
        return [[{"type": t.kind, **t.params()} for t in lvl] for lvl in self.levels]

    def to_yaml(self) -> str:
        """YAML of :meth:`to_list`; ``wbc.config.build_stack(yaml.safe_load(text))`` rebuilds
        the same stack (same tasks, gains, weights and targets)."""
        import yaml

        return yaml.safe_dump(self.to_list(), sort_keys=False, allow_unicode=True)

    def __repr__(self) -> str:
        return "Stack(" + " / ".join("[" + ", ".join(t.name for t in lvl) + "]" for lvl in self.levels) + ")"

    # ------------------------------------------------------------ per cycle
    def layout(self, robot) -> Layout:
        """Force variables: one block per contact task, in stack order. The Layout is
        reused (its J_f refilled) while the stack's structure is unchanged: like the
        levels, it is valid until the next call."""
        key = (self.version, id(robot))
        got = self.__dict__.get("_layout")
        if got is not None and got[0] == key:
            layout, parts = got[1], got[2]
            for c, rows in parts:
                layout.force_jacobian[rows] = c.force_jacobian(robot)
            return layout
        contacts = self.contacts()
        slices, jacs, parts, k = {}, [], [], robot.nv
        for c in contacts:
            c.surface(robot)
            d = c.force_dim
            slices[c.name] = slice(k, k + d)
            parts.append((c, slice(k - robot.nv, k - robot.nv + d)))
            jacs.append(c.force_jacobian(robot))
            k += d
        layout = Layout(nv=robot.nv, contact_slices=slices, force_jacobian=np.vstack(jacs) if jacs else None)
        self._layout = (key, layout, parts)
        return layout

    def assemble(self, robot, layout: Layout, extra_level0: Iterable[Task] = ()) -> list[Level]:
        """Rows of every level for the robot's current state (``robot.update`` done).

        The levels' arrays are buffers this stack owns and refills every cycle (they
        are reallocated only when the stack's structure changes): a Level is valid
        until the next call."""
        buffers = self.__dict__.setdefault("_buffers", {})
        levels = []
        tasks_per_level = [list(extra_level0) + (self.levels[0] if self.levels else [])] + self.levels[1:]
        for k, tasks in enumerate(tasks_per_level):
            levels.append(assemble_level(k, tasks, robot, layout, buffers))
        return levels


class _LevelBuffer:
    """Preallocated arrays of one level: A, b, and every inequality row (the tasks'
    general rows, then the box bounds as unit rows, set once)."""

    def __init__(self, sig: tuple, tasks: list[Task], rows: list[Rows], nx: int) -> None:
        self.sig = sig
        self.eq_slices, self.in_slices, self.eq_parts, self.in_parts, self.box_parts = {}, {}, [], [], []
        ne = ni = 0
        for t, r in zip(tasks, rows):
            if r.A is not None:
                sl = slice(ne, ne + r.A.shape[0])
                self.eq_slices[t.name] = sl
                w = float(np.sqrt(t.weight))
                self.eq_parts.append((sl, w))
                ne = sl.stop
            if r.C is not None and r.C.shape[0]:
                sl = slice(ni, ni + r.C.shape[0])
                self.in_slices[t.name] = sl
                self.in_parts.append(sl)
                ni = sl.stop
        self.n_gen = ni
        idx = [r.box[0] for r in rows if r.box is not None]
        self.box_srcs = idx           # the tasks' index arrays (identity check next cycle)
        self.box_idx = np.concatenate(idx).astype(int) if idx else None
        nb = 0 if self.box_idx is None else len(self.box_idx)
        # box slices, in order, in the all-inequalities arrays
        self.box_parts, k = [], ni
        for r in rows:
            if r.box is not None:
                self.box_parts.append(slice(k, k + len(r.box[0])))
                k += len(r.box[0])
        self.A = np.zeros((ne, nx))
        self.b = np.zeros(ne)
        self.C_all = np.zeros((ni + nb, nx))
        self.lo_all = np.zeros(ni + nb)
        self.hi_all = np.zeros(ni + nb)
        if nb:
            self.C_all[ni + np.arange(nb), self.box_idx] = 1.0
        # each task's part of the arrays as views, made once
        self.eq_views = [(self.A[sl], self.b[sl], w) for sl, w in self.eq_parts]
        self.in_views = [(self.C_all[sl], self.lo_all[sl], self.hi_all[sl]) for sl in self.in_parts]
        self.box_views = [(self.lo_all[sl], self.hi_all[sl]) for sl in self.box_parts]
        #: the Level handed out, reused while the structure is unchanged (its arrays
        #: are these buffers)
        self.level: Level | None = None


def assemble_level(k: int, tasks: list[Task], robot, layout: Layout, buffers: dict | None = None) -> Level:
    """Stack the rows of one level's tasks into (reused) buffers; box bounds on q̈ are
    kept apart as ``box`` and also appended as unit rows to the level's inequalities."""
    nx = layout.nx
    rows = [t.rows(robot, layout) for t in tasks]
    if len(rows) == 1 and buffers is not None:
        lvl = _single_task_level(k, tasks[0], rows[0], nx, buffers)
        if lvl is not None:
            return lvl
    sig = (nx,) + tuple((id(t), r.n_eq, 0 if r.C is None else r.C.shape[0], None if r.box is None else len(r.box[0]),
                         t.weight) for t, r in zip(tasks, rows))
    buf = None if buffers is None else buffers.get(k)
    if buf is not None and not isinstance(buf, _LevelBuffer):
        buf = None
    if buf is not None and buf.box_idx is not None:
        ng = buf.n_gen
        srcs = [r.box[0] for r in rows if r.box is not None]
        same_box = (len(srcs) == len(buf.box_srcs) and all(a is b for a, b in zip(srcs, buf.box_srcs))) or all(
            np.array_equal(a, buf.box_idx[sl.start - ng: sl.stop - ng]) for a, sl in zip(srcs, buf.box_parts))
        if same_box:
            buf.box_srcs = srcs
    else:
        same_box = True
    if buf is None or buf.sig != sig or not same_box:
        buf = _LevelBuffer(sig, tasks, rows, nx)
        if buffers is not None:
            buffers[k] = buf
    eq = iter(buf.eq_views)
    ineq = iter(buf.in_views)
    boxes = iter(buf.box_views)
    copyto = np.copyto
    for r in rows:
        if r.A is not None:
            A, b, w = next(eq)
            if w == 1.0:
                copyto(A, r.A)
                copyto(b, r.b)
            else:
                np.multiply(r.A, w, out=A)
                np.multiply(r.b, w, out=b)
        if r.C is not None and r.C.shape[0]:
            C, lo, hi = next(ineq)
            copyto(C, r.C)
            copyto(lo, r.lo)
            copyto(hi, r.hi)
        if r.box is not None:
            lo, hi = next(boxes)
            copyto(lo, r.box[1])
            copyto(hi, r.box[2])
    if buf.level is not None:
        return buf.level
    ng = buf.n_gen
    box = None
    if buf.box_idx is not None:
        box = (buf.box_idx, buf.lo_all[ng:], buf.hi_all[ng:])
    lvl = Level(index=k, tasks=list(tasks), A=buf.A, b=buf.b, C=buf.C_all[:ng], lo=buf.lo_all[:ng],
                hi=buf.hi_all[:ng], box=box, eq_slices=buf.eq_slices, in_slices=buf.in_slices)
    lvl._ineq = (buf.C_all, buf.lo_all, buf.hi_all)
    if buffers is not None:
        buf.level = lvl
    return lvl


def _single_task_level(k: int, task: Task, r: Rows, nx: int, buffers: dict) -> Level | None:
    """A level of one unweighted equality task (a CoM, a posture): its Level views the
    task's own row buffers (which, like the level buffers, live until the next cycle),
    nothing is copied. None when the task has inequality rows or a weight."""
    if r.A is None or r.C is not None or r.box is not None or task.weight != 1.0 or r.A.shape[1] != nx:
        return None
    key = ("single", id(task), r.A.shape[0], nx)
    got = buffers.get(k)
    if not (isinstance(got, list) and got[0] == key and got[1] is task):
        empty = (np.zeros((0, nx)), np.zeros(0), np.zeros(0))
        got = buffers[k] = [key, task, {task.name: slice(0, r.A.shape[0])}, empty, None]
    _, _, eq_slices, empty, lvl = got
    if lvl is not None and lvl.A is r.A and lvl.b is r.b:
        return lvl                  # the same task buffers: the same Level
    lvl = Level(index=k, tasks=[task], A=r.A, b=r.b, C=empty[0], lo=empty[1], hi=empty[2], box=None,
                eq_slices=eq_slices, in_slices={})
    lvl._ineq = empty
    got[4] = lvl
    return lvl
