"""Stack: the task hierarchy, ordered levels of weighted tasks (index 0 = highest).

Per cycle the stack turns its tasks into plain data for the solvers: a
:class:`~wbc.problem.rows.Layout` (where each contact's force lives in x) and one
:class:`~wbc.problem.rows.Level` per priority, with the rows of its tasks stacked and
each task's equality rows scaled by √weight, so a level minimises
Σ_i w_i ‖A_i x − b_i‖².
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np

from .errors import StackError
from .problem.buffer import RowBuffer
from .problem.rows import Layout, Level
from .tasks.base import Task
from .tasks.contact import Contact
from .tasks.group import TaskGroup, builds
from .tasks.torque_stack import TorquePlan, torque_plan


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


@builds
class Stack:
    """Ordered priority levels, each a list of tasks; tasks addressable by name.
    ``(a + b) / c`` builds one too (:mod:`wbc.tasks.group`).

    Args:
        levels: the levels, highest first; each a :class:`~wbc.tasks.Task`, a task group
            (``a + b``) or a list of tasks. Default: no level. Two tasks of one name, or a
            level that holds something else than tasks, is a StackError.
    """

    #: (buffer, extra_level0, extra_lowest, version, nx) of :meth:`_hold_args` (a class default:
    #: a stack pickled before it has none)
    _held_args: tuple | None = None

    def __init__(self, levels: Iterable = ()) -> None:
        self._levels: list[list[Task]] = []
        #: bumped by every change of structure; the caches below are valid for one version
        self.version = 0
        self._view: tuple = (-1, ())            # (version, the levels as tuples) of :attr:`levels`
        self._contacts: tuple | None = None     # (version, contact tasks)
        self._layout: tuple | None = None       # (key, Layout, its force-Jacobian blocks)
        self._row_buffer: RowBuffer | None = None
        #: (the buffer it is for, its plan or None: no plan for it) of :func:`torque_plan`
        self._plan: tuple[RowBuffer, TorquePlan | None] | None = None
        #: (robot, layout, blocks) of a J_f refill :meth:`layout` left to the plan (``deferred``)
        self._forces_due: tuple | None = None
        for lvl in levels:
            self._levels.append(_as_level(lvl))
        self._check_names()

    @property
    def levels(self) -> tuple[tuple[Task, ...], ...]:
        """The levels, highest first, each a tuple of its tasks: a read-only view. The stack
        changes through :meth:`add`, :meth:`remove`, :meth:`move` and :meth:`replace` only,
        which bump :attr:`version`; a controller plans again on a new version, and would not
        see a task put into a level's list by hand (it kept solving for the old one)."""
        view = self._view
        if view[0] != self.version:
            view = self._view = (self.version, tuple(tuple(lvl) for lvl in self._levels))
        return view[1]

    def __getstate__(self) -> dict:
        """A copy or a pickle plans again: the plan holds its arrays' addresses, which a copy's
        arrays do not have."""
        state = self.__dict__.copy()
        state["_plan"] = None
        state["_forces_due"] = None
        state["_held_args"] = None
        return state

    def _check_names(self) -> None:
        seen: dict[str, int] = {}
        for k, lvl in enumerate(self._levels):
            for t in lvl:
                if t.name in seen:
                    raise StackError(
                        f"two tasks are named '{t.name}' (levels {seen[t.name]} and {k}); names must be unique"
                    )
                seen[t.name] = k
        self.version += 1

    # ------------------------------------------------------------- building
    def __truediv__(self, other) -> Stack:
        """``stack / level``: a new stack with ``other`` as one more, lowest, level.

        Args:
            other: a task, a task group or a list of tasks.
        """
        return Stack(self._levels + [_as_level(other)])

    def __getitem__(self, name: str) -> Task:
        """The task named ``name``; a KeyError listing the stack's tasks if none.

        Args:
            name: the task's name (``Task.name``).
        """
        for lvl in self._levels:
            for t in lvl:
                if t.name == name:
                    return t
        raise KeyError(f"no task named '{name}' in the stack; tasks: {self.names()}")

    def __contains__(self, name: str) -> bool:
        """Whether a task of the stack is named ``name``.

        Args:
            name: a task name.
        """
        return name in self.names()

    def __iter__(self) -> Iterator[Task]:
        for lvl in self._levels:
            yield from lvl

    def __len__(self) -> int:
        return len(self._levels)

    def names(self) -> list[str]:
        """The tasks' names, level by level, highest first."""
        return [t.name for t in self]

    def level_of(self, name: str) -> int:
        """The level index (0 = highest) of the task named ``name``; a KeyError if none.

        Args:
            name: the task's name.
        """
        for k, lvl in enumerate(self._levels):
            if any(t.name == name for t in lvl):
                return k
        raise KeyError(f"no task named '{name}' in the stack; tasks: {self.names()}")

    def add(self, task: Task, level: int) -> None:
        """Insert ``task`` in ``level``.

        Args:
            task: the task; its name must not be in the stack yet (else a StackError, the
                stack unchanged).
            level: level index, 0 (highest) to ``len(stack)`` (appends a new lowest level);
                outside that range a StackError.
        """
        if not 0 <= level <= len(self._levels):
            raise StackError(f"level must be in [0, {len(self._levels)}], got {level}")
        new_level = level == len(self._levels)
        if new_level:
            self._levels.append([])
        self._levels[level].append(task)
        try:
            self._check_names()
        except StackError:
            self._levels[level].pop()
            if new_level:
                del self._levels[level]
            raise

    def remove(self, name: str) -> Task:
        """Remove the task named ``name`` (empty levels are dropped) and return it.

        Args:
            name: the task's name; a KeyError if none.
        """
        k = self.level_of(name)
        task = self[name]
        self._levels[k].remove(task)
        if not self._levels[k]:
            del self._levels[k]
        self._check_names()
        return task

    def replace(self, name: str, task: Task) -> Task:
        """Put ``task`` in the place (level and order) of the task named ``name``, and return
        the one it replaces.

        Args:
            name: the name of the task to replace; a KeyError if none.
            task: the new task; its name must be ``name`` or a name not in the stack yet (else
                a StackError, the stack unchanged).
        """
        k = self.level_of(name)
        old = self[name]
        if not isinstance(task, Task):
            raise StackError(f"a stack level holds tasks, got {type(task).__name__} to replace '{name}'")
        j = next(i for i, t in enumerate(self._levels[k]) if t is old)
        self._levels[k][j] = task
        try:
            self._check_names()
        except StackError:
            self._levels[k][j] = old
            raise
        return old

    def move(self, name: str, level: int) -> None:
        """Re-prioritise a task: remove it, then add it at ``level``.

        Args:
            name: the task's name; a KeyError if none.
            level: its new level index, counted after the removal (0 = highest); beyond the
                last level it goes to a new lowest one.
        """
        task = self.remove(name)
        self.add(task, min(level, len(self._levels)))

    def contacts(self) -> list[Contact]:
        """The stack's :class:`~wbc.tasks.Contact` tasks, in stack order (a new list)."""
        got = self._contacts
        if got is None or got[0] != self.version:
            got = self._contacts = (self.version, [t for t in self if isinstance(t, Contact)])
        return list(got[1])

    def to_list(self) -> list[list[dict]]:
        """The stack as plain data: levels of ``{type: ..., <constructor arguments>}``."""
        return [[{"type": t.kind, **t.params()} for t in lvl] for lvl in self._levels]

    def to_yaml(self) -> str:
        """YAML of :meth:`to_list`; ``wbc.scenario.build_tasks.build_stack(yaml.safe_load(text))`` rebuilds
        the same stack (same tasks, gains, weights and targets)."""
        import yaml

        return yaml.safe_dump(self.to_list(), sort_keys=False, allow_unicode=True)

    def __repr__(self) -> str:
        return "Stack(" + " / ".join("[" + ", ".join(t.name for t in lvl) + "]" for lvl in self._levels) + ")"

    # ------------------------------------------------------------ per cycle
    def layout(self, robot, deferred: bool = False) -> Layout:
        """Force variables: one block per contact task, in stack order. The Layout is
        reused (its J_f refilled) while the stack's structure is unchanged: like the
        levels, it is valid until the next call.

        Args:
            robot: the :class:`~wbc.robot.model.RobotModel`, updated to this cycle's state.
            deferred: for a caller whose next use of J_f is :meth:`assemble`'s (the controller's
                cycle): when the stack's torque plan writes J_f in its compiled call
                (:attr:`~wbc.tasks.torque_stack.TorquePlan.fills_forces`), J_f is left for it
                (the same bits: pinocchio's frame Jacobian written out), and :meth:`assemble`
                refills it from pinocchio if the plan does not run that cycle. Default False:
                J_f refilled here.
        """
        key = (self.version, id(robot))
        got = self._layout
        if got is not None and got[0] == key:
            layout, parts = got[1], got[2]
            plan = self._plan
            if deferred and plan is not None and plan[1] is not None and plan[0] is self._row_buffer \
                    and plan[1].layout is layout and plan[1].fills_forces:
                self._forces_due = (robot, layout, parts)
                return layout
            self._forces_due = None
            _refill_forces(robot, layout, parts)
            return layout
        self._forces_due = None
        contacts = self.contacts()
        slices, jacs, parts, k = {}, [], [], robot.nv
        for c in contacts:
            c.surface(robot)
            d = c.force_dim
            slices[c.name] = slice(k, k + d)
            parts.append((c, slice(k - robot.nv, k - robot.nv + d)))
            jacs.append(c.force_jacobian(robot))
            k += d
        layout = Layout(nv=robot.nv, contact_slices=slices, force_jacobian=np.vstack(jacs) if jacs else None,
                        surfaces={c.name: c.surface(robot) for c in contacts})
        self._layout = (key, layout, parts)
        return layout

    def assemble(self, robot, layout: Layout, extra_level0: Iterable[Task] = (),
                 extra_lowest: Iterable[Task] = ()) -> list[Level]:
        """Rows of every level for the robot's current state (``robot.update`` done).

        The levels' arrays are views of one buffer this stack owns and refills every
        cycle (:class:`RowBuffer`; rebuilt only when the stack's structure changes): a
        Level is valid until the next call. Each task writes its equality rows into the
        buffer's :class:`~wbc.problem.rows.RowSlot` handed to its ``rows`` call.

        Args:
            robot: the :class:`~wbc.robot.model.RobotModel`, updated to this cycle's state.
            layout: this cycle's :meth:`layout` (where each contact's force lives in x).
            extra_level0: tasks the controller adds to level 0 (the floating-base dynamics);
                default none.
            extra_lowest: tasks it adds as one more level below the stack's own (the default
                contact regularisation), which is then always the lowest, whatever levels
                events add; default none.
        """
        buf = self._row_buffer
        held = self._held_args
        if held is not None and buf is not None and held[0] is buf and held[1] is extra_level0 \
                and held[2] is extra_lowest and held[3] == self.version and held[4] == layout.nx:
            same = True                           # the same tuples of tasks for this buffer: its key
            key = buf.key
        else:
            key = (self.version, layout.nx, tuple(map(id, extra_level0)), tuple(map(id, extra_lowest)))
            same = buf is not None and buf.key == key
            self._hold_args(buf if same else None, extra_level0, extra_lowest, layout.nx)
        if same:
            plan = self._plan
            if plan is not None and plan[0] is buf and plan[1] is not None:
                # the known tasks' rows in one compiled call (wbc.tasks.torque_stack)
                if plan[1].write(robot, layout):
                    self._forces_due = None        # J_f written by the plan's call
                    return buf.levels
                called = plan[1].called            # the tasks it called this cycle: not called again
                plan = self._plan = None           # a change it does not follow: the tasks, then plan again
            else:
                called = {}
        extra, lowest = list(extra_level0), list(extra_lowest)
        groups = [extra + (self._levels[0] if self._levels else [])] + self._levels[1:]
        if lowest:
            groups.append(lowest)                 # (the tasks by level: built only when they are called)
        if same and buf is not None:
            self._due_forces()
            # each task writes its equality rows into its slot of the buffer (for this call
            # only), and its other rows are put in as they come; rows: the structure changed
            rows = buf.refill(robot, layout, groups, called)
            if rows is None:
                if plan is None or plan[0] is not buf:
                    self._plan = (buf, torque_plan(groups, buf, robot, layout))
                return buf.levels
        else:
            self._due_forces()
            rows = [[t.rows(robot, layout) for t in tasks] for tasks in groups]
        buf = self._row_buffer = RowBuffer(layout.nx, groups, rows, key=key)
        buf.fill(groups, rows)
        self._hold_args(buf, extra_level0, extra_lowest, layout.nx)
        return buf.levels

    def _hold_args(self, buf: RowBuffer | None, extra_level0, extra_lowest, nx: int) -> None:
        """:meth:`assemble`'s arguments for the buffer they match (its key checked), held when they
        are tuples (immutable: the same objects are the same tasks) so that the next call with the
        same objects, version and nx skips building the key; None otherwise."""
        ok = buf is not None and type(extra_level0) is tuple and type(extra_lowest) is tuple
        self._held_args = (buf, extra_level0, extra_lowest, self.version, nx) if ok else None

    def _due_forces(self) -> None:
        """The J_f refill :meth:`layout` left to a plan that did not run (before any task's rows)."""
        due = self._forces_due
        if due is not None:
            self._forces_due = None
            _refill_forces(*due)

    @property
    def row_buffer(self) -> RowBuffer | None:
        """The buffer behind the levels of the last :meth:`assemble`."""
        return self._row_buffer


def _refill_forces(robot, layout: Layout, parts: list) -> None:
    """Each contact's rows of J_f from pinocchio (``Contact.force_jacobian``), in place."""
    Jf = layout.force_jacobian
    if Jf is None:                                 # no contact: no blocks
        return
    for c, rows in parts:
        Jf[rows] = c.force_jacobian(robot)


def assemble_level(k: int, tasks: list[Task], robot, layout: Layout) -> Level:
    """One level's rows stacked into fresh arrays (what :meth:`Stack.assemble` gives as
    views of its reused buffer)."""
    rows = [[t.rows(robot, layout) for t in tasks]]
    buf = RowBuffer(layout.nx, [tasks], rows, first_index=k)
    buf.fill([tasks], rows)
    return buf.levels[0]
