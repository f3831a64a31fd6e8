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
        return [t for t in self if isinstance(t, Contact)]

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
        """Force variables: one block per contact task, in stack order."""
        contacts = self.contacts()
        slices, jacs, k = {}, [], robot.nv
        for c in contacts:
            c.surface(robot)
            d = c.force_dim
            slices[c.name] = slice(k, k + d)
            jacs.append(c.force_jacobian(robot))
            k += d
        return Layout(nv=robot.nv, contact_slices=slices, force_jacobian=np.vstack(jacs) if jacs else None)

    def assemble(self, robot, layout: Layout, extra_level0: Iterable[Task] = ()) -> list[Level]:
        """Rows of every level for the robot's current state (``robot.update`` done)."""
        levels = []
        tasks_per_level = [list(extra_level0) + (self.levels[0] if self.levels else [])] + self.levels[1:]
        for k, tasks in enumerate(tasks_per_level):
            levels.append(assemble_level(k, tasks, robot, layout))
        return levels


def assemble_level(k: int, tasks: list[Task], robot, layout: Layout) -> Level:
    """Stack the rows of one level's tasks; box bounds on q̈ are kept apart."""
    nx = layout.nx
    A_parts, b_parts, C_parts, lo_parts, hi_parts = [], [], [], [], []
    box_idx, box_lo, box_hi = [], [], []
    eq_slices, in_slices = {}, {}
    ne = ni = 0
    for t in tasks:
        r: Rows = t.rows(robot, layout)
        if r.A is not None:
            w = np.sqrt(t.weight)
            A_parts.append(r.A * w if w != 1.0 else r.A)
            b_parts.append(r.b * w if w != 1.0 else r.b)
            eq_slices[t.name] = slice(ne, ne + r.A.shape[0])
            ne += r.A.shape[0]
        start = ni
        if r.C is not None:
            C_parts.append(r.C)
            lo_parts.append(r.lo)
            hi_parts.append(r.hi)
            ni += r.C.shape[0]
        if ni > start:
            in_slices[t.name] = slice(start, ni)
        if r.box is not None:
            box_idx.append(r.box[0])
            box_lo.append(r.box[1])
            box_hi.append(r.box[2])
    A = np.vstack(A_parts) if A_parts else np.zeros((0, nx))
    b = np.concatenate(b_parts) if b_parts else np.zeros(0)
    C = np.vstack(C_parts) if C_parts else np.zeros((0, nx))
    lo = np.concatenate(lo_parts) if lo_parts else np.zeros(0)
    hi = np.concatenate(hi_parts) if hi_parts else np.zeros(0)
    box = None
    if box_idx:
        box = (np.concatenate(box_idx), np.concatenate(box_lo), np.concatenate(box_hi))
    return Level(index=k, tasks=list(tasks), A=A, b=b, C=C, lo=lo, hi=hi, box=box,
                 eq_slices=eq_slices, in_slices=in_slices)
