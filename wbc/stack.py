"""Stack: the task hierarchy, ordered levels of weighted tasks (index 0 = highest).

Per cycle the stack turns its tasks into plain data for the solvers: a
:class:`~wbc.rows.Layout` (where each contact's force lives in x) and one
:class:`~wbc.rows.Level` per priority, with the rows of its tasks stacked and
each task's equality rows scaled by √weight, so a level minimises
Σ_i w_i ‖A_i x − b_i‖².
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numba as nb
import numpy as np

from .errors import StackError
from .rows import Layout, Level, Rows
from .tasks.base import Task
from .tasks.contact import Contact
from .tasks.group import TaskGroup, builds


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
    ``(a + b) / c`` builds one too (:mod:`wbc.tasks.group`)."""

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
    def __truediv__(self, other) -> Stack:
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
        layout = Layout(nv=robot.nv, contact_slices=slices, force_jacobian=np.vstack(jacs) if jacs else None,
                        surfaces={c.name: c.surface(robot) for c in contacts})
        self._layout = (key, layout, parts)
        return layout

    def assemble(self, robot, layout: Layout, extra_level0: Iterable[Task] = (),
                 extra_lowest: Iterable[Task] = ()) -> list[Level]:
        """Rows of every level for the robot's current state (``robot.update`` done).

        ``extra_level0``: tasks the controller adds to level 0 (the floating-base dynamics);
        ``extra_lowest``: tasks it adds as one more level below the stack's own (the default
        contact regularisation), which is then always the lowest, whatever levels events add.

        The levels' arrays are views of one buffer this stack owns and refills every
        cycle (:class:`RowBuffer`; rebuilt only when the stack's structure changes): a
        Level is valid until the next call."""
        extra = list(extra_level0)
        lowest = list(extra_lowest)
        groups = [extra + (self.levels[0] if self.levels else [])] + self.levels[1:]
        if lowest:
            groups.append(lowest)
        rows = [[t.rows(robot, layout) for t in tasks] for tasks in groups]
        key = (self.version, layout.nx, tuple(map(id, extra)), tuple(map(id, lowest)))
        buf = self.__dict__.get("_row_buffer")
        if buf is None or buf.key != key or not buf.fill(groups, rows):
            buf = self._row_buffer = RowBuffer(layout.nx, groups, rows, key=key, adopt=True)
            buf.fill(groups, rows)
        return buf.levels

    @property
    def row_buffer(self) -> RowBuffer | None:
        """The buffer behind the levels of the last :meth:`assemble`."""
        return self.__dict__.get("_row_buffer")


class RowBuffer:
    """Every level's rows in five stack-wide arrays: A, b (equalities, each task's rows
    scaled by √weight) and C, l, u (inequalities; per level the tasks' general rows, then
    the box bounds as unit rows, set once). Each level is a block of rows, and its Level
    holds views of that block, so the solvers see levels while one product per array
    evaluates every level's rows (:func:`row_values`). Built for one structure (tasks, their
    row counts, weights and box indices); :meth:`fill` refuses another.

    With ``adopt`` (the stack's own buffer), a task of weight 1 that keeps its rows in
    :func:`~wbc.tasks.base.eq_buffer` is handed its block of A and b as that buffer:
    it then writes its rows in place and nothing is copied. A task shared by two stacks
    moves to whichever assembled last (both stay right; a Level of the other stack is
    then only valid until this one's next call)."""

    def __init__(self, nx: int, groups: list[list[Task]], rows: list[list[Rows]], first_index: int = 0,
                 key=None, adopt: bool = False) -> None:
        self.nx, self.key, self.adopt = nx, key, adopt
        ne = sum(r.n_eq for rs in rows for r in rs)
        ni = sum(r.n_in for rs in rows for r in rs)
        self.A, self.b = np.zeros((ne, nx)), np.zeros(ne)
        self.C, self.lo, self.hi = np.zeros((ni, nx)), np.zeros(ni), np.zeros(ni)
        self.plans, self.levels, self.spans = [], [], []
        e = i = 0
        for k, (tasks, rs) in enumerate(zip(groups, rows)):
            e0, i0 = e, i
            ng = sum(r.C.shape[0] for r in rs if r.C is not None)
            g, bx = i0, i0 + ng
            eq_slices, in_slices, plan, box_idx = {}, {}, [], []
            for t, r in zip(tasks, rs):
                eqv = inv = boxv = None
                if r.A is not None:
                    m = r.A.shape[0]
                    eq_slices[t.name] = slice(e - e0, e - e0 + m)
                    eqv = (self.A[e:e + m], self.b[e:e + m], float(np.sqrt(t.weight)))
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
            i = bx
            box = None
            if box_idx:
                box = (np.concatenate(box_idx), self.lo[i0 + ng:i], self.hi[i0 + ng:i])
            lvl = Level(index=first_index + k, tasks=list(tasks), A=self.A[e0:e], b=self.b[e0:e],
                        C=self.C[i0:i0 + ng], lo=self.lo[i0:i0 + ng], hi=self.hi[i0:i0 + ng], box=box,
                        eq_slices=eq_slices, in_slices=in_slices)
            lvl._ineq = (self.C[i0:i], self.lo[i0:i], self.hi[i0:i])
            lvl.buffer = self
            self.plans.append(plan)
            self.levels.append(lvl)
            self.spans.append((e0, e, i0, ng, i))
        #: where each level's equality and inequality rows end in (A, b) and (C, lo, hi)
        self.eq_end = np.array([sp[1] for sp in self.spans], dtype=np.int64)
        self.ineq_end = np.array([sp[4] for sp in self.spans], dtype=np.int64)

    def fill(self, groups: list[list[Task]], rows: list[list[Rows]]) -> bool:
        """Copy this cycle's rows in; False (nothing to trust) if they no longer have
        the structure the buffer was built for."""
        if len(rows) != len(self.plans):
            return False
        copyto = np.copyto
        for plan, rs, tasks in zip(self.plans, rows, groups):
            if len(rs) != len(plan):
                return False
            for (w0, eqv, inv, boxv), r, t in zip(plan, rs, tasks):
                if t.weight != w0:
                    return False
                rA = r.A
                if rA is not None:
                    if eqv is None:
                        return False
                    A, b, w = eqv
                    if rA is A and r.b is b:
                        pass                        # written in place (see below)
                    elif rA.shape != A.shape:
                        return False
                    elif w == 1.0:
                        copyto(A, rA)
                        copyto(b, r.b)
                        if self.adopt and _owns_rows(t, r):
                            # from now on the task writes its rows straight into the
                            # buffer: eq_buffer hands it these views
                            t._eq_buf = (A, b)
                    else:
                        np.multiply(rA, w, out=A)
                        np.multiply(r.b, w, out=b)
                elif eqv is not None:
                    return False
                rC = r.C
                if rC is not None and len(rC):
                    if inv is None or rC.shape != inv[0].shape:
                        return False
                    C, lo, hi = inv
                    copyto(C, rC)
                    copyto(lo, r.lo)
                    copyto(hi, r.hi)
                elif inv is not None:
                    return False
                if r.box is not None:
                    if boxv is None:
                        return False
                    lo, hi, src, idx = boxv
                    if r.box[0] is not src and not np.array_equal(r.box[0], idx):
                        return False
                    copyto(lo, r.box[1])
                    copyto(hi, r.box[2])
                elif boxv is not None:
                    return False
        return True


def buffered_prefix(levels: list[Level]) -> tuple[RowBuffer | None, int]:
    """(the row buffer behind ``levels``, how many leading levels are its own levels in
    order): what a compiled solver run may read straight from the buffer's arrays."""
    buf = getattr(levels[0], "buffer", None) if levels else None
    n = 0
    if buf is not None:
        for lvl, own in zip(levels, buf.levels):
            if lvl is not own:
                break
            n += 1
    return buf, n


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
    out[:ne] = A @ x - b if ne else out[:0]
    out[ne:ne + ni] = C @ x if ni else out[:0]
    out[ne + ni:ne + 2 * ni] = lo
    out[ne + 2 * ni:ne + 3 * ni] = hi
    out[ne + 3 * ni:] = b
    return out


def _owns_rows(t: Task, r: Rows) -> bool:
    """Whether the task's equality rows are its :func:`~wbc.tasks.base.eq_buffer` arrays."""
    own = getattr(t, "_eq_buf", None)
    return own is not None and own[0] is r.A and own[1] is r.b


def assemble_level(k: int, tasks: list[Task], robot, layout: Layout) -> Level:
    """One level's rows stacked into fresh arrays (what :meth:`Stack.assemble` gives as
    views of its reused buffer)."""
    rows = [[t.rows(robot, layout) for t in tasks]]
    buf = RowBuffer(layout.nx, [tasks], rows, first_index=k)
    buf.fill([tasks], rows)
    return buf.levels[0]
