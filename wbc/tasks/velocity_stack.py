"""A velocity stack's rows in one compiled call (:mod:`wbc.controller.velocity_plan`).

Each task's velocity writer (:func:`wbc.tasks.velocity.velocity_writer`) is one compiled call
of 7-13 arguments; numba's dispatch costs ~1 µs a call and ~0.2 µs an argument (~0.3 in a
tuple), so five writers spent ~15 µs crossing into compiled code for ~2 µs of arithmetic.
:func:`stack_writer` makes, from the writers' specs (the arrays each writer holds), one writer
for the point frames, the contacts, one CoM, one posture and one joint-limit task of a stack:
one call of :func:`_stack_rows` with eight arguments, which calls the writers' own kernels
(:func:`~wbc.tasks.velocity_frames.frame_rows`, :func:`~wbc.tasks.velocity._motion_rows`,
:func:`~wbc.tasks.velocity._joint_velocity_bounds`) on the blocks of the row buffer: the same
rows, bit for bit (``tests/tasks/test_velocity_stack.py``).

What is held and what is read each cycle.

- Held constants (the plan's structure), in one int and one float table: each block's first
  row in the buffer, the selections, the joint-limit task's joints and limits, and the gains
  K, copied into the float table only when a task's ``kp`` is replaced (the writers' own rule,
  :class:`~wbc.tasks.velocity._Gain`; the copy keeps its own record of the kp it copied, so a
  cycle written by the writers does not leave the table stale).
- Arrays read in place, by address: the arrays the kernel reads are many (per frame its
  placement, its target's rotation, translation and velocity) and each argument costs
  dispatch, so their data addresses are held in one int table ``at`` (:data:`_NE` …), each
  array (or the object it is a view of) kept alive beside its address. pinocchio's
  (``data.J``, each frame's placement, the CoM, J_com) and the buffer's are fixed for the
  plan's life; a target's address is written again when the task's target object is replaced
  (checked by identity), and a target changed in place is read as it is now.
- The Python checks (the gains, the targets' objects, a contact's sliding, a CoM's axes, the joint
  limits' settings) run once per change, not once per cycle: every attribute they read is a
  watched one (:class:`wbc.tasks.base.Watched`, or a target's setter), whose assignment bumps
  :data:`wbc.tasks.base.TASK_CHANGES`; their answer is kept while the count stays (~5 µs a cycle
  interleaved with other solvers, ``benchmarks/ik_peers.md``).
- Passed each cycle: q, the joint-limit task's margin and gain, and the posture's error
  (pinocchio's ``difference``, the task's own ``error``) unless every joint it drives is a
  vector space of one coordinate (bounded revolute, prismatic: ``difference`` is q_d − q there),
  when the call computes it from q and the posture's target, held by address as the others'
  (the same subtraction, bit for bit).

A cycle the call cannot write (a target not set yet or not a contiguous float64 array, a
contact's logarithm near a half turn, a rate-limited joint-limit task) is written by the
writers instead; a task whose rows changed shape says so as its writer does (plan again).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numba as nb
import numpy as np
from numba import types
from numba.extending import intrinsic

from .base import TASK_CHANGES
from .velocity import Writer, _joint_velocity_bounds, _motion_rows
from .velocity_frames import frame_rows

__all__ = ["stack_writer"]

#: the address table's slots (``at``): sizes, the buffer's and pinocchio's arrays, then per
#: frame its placement (R, p), its target's (R_t, p_t) and target velocity, then the CoM's
#: target and target velocity
_NE, _NI, _NV, _NJ, _A, _B, _LO, _HI, _J, _COM, _JCOM = range(11)
_FRAMES, _PER_FRAME = 11, 5
#: the int table's header (``ix``): frames; where the CoM's, posture's, limits' entries start
#: in ``ix`` and in the float table ``fx`` (−1: none)
_NF, _COM_I, _POST_I, _LIM_I, _COM_F, _POST_F, _LIM_F = range(7)
_HEADER = 7
#: a frame's entries in ``ix``: first row, rows, 6-D contact (log₆, local Jacobian), selection (6)
_FRAME_INTS = 9


def _address_intrinsic(element, name: str):
    """An intrinsic that turns an address (int64) into a pointer to ``element`` (a numba type): a held array's data
    (module docstring), for ``nb.carray`` / ``nb.farray`` in a kernel."""
    def typer(typingctx, address):
        sig = types.CPointer(element)(types.int64)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    typer.__name__ = typer.__qualname__ = name
    return intrinsic(typer)


#: the float64 pointer at an address (int64)
float_pointer = _address_intrinsic(types.float64, "float_pointer")
#: the int64 pointer at an address (int64)
int_pointer = _address_intrinsic(types.int64, "int_pointer")


@nb.njit(cache=True)
def _vector(address, n):
    """The n-vector of float64 at ``address``."""
    return nb.carray(float_pointer(address), n)


@nb.njit(cache=True)
def _matrix(address, rows, cols):
    """The rows × cols column-major (Eigen's, pinocchio's) matrix of float64 at ``address``."""
    return nb.farray(float_pointer(address), (rows, cols))


@nb.njit(cache=True)
def _stack_rows(at, ix, fx, support, q, post_e, margin, k):
    """Every covered task's rows (module docstring) into the buffer's A, b and box bounds lo, hi,
    the arrays read at the addresses ``at``, the constants in ``ix`` and ``fx``. Returns False
    (the writers are to write this cycle) when a contact's logarithm is near a half turn
    (:func:`frame_rows`)."""
    ne, ni, nv, nj = at[_NE], at[_NI], at[_NV], at[_NJ]
    A = nb.carray(float_pointer(at[_A]), (ne, nv))
    b = _vector(at[_B], ne)
    J = _matrix(at[_J], 6, nj)
    e = np.zeros(6)
    nf = ix[_NF]
    for i in range(nf):
        c = _HEADER + _FRAME_INTS * i
        r0, m = ix[c], ix[c + 1]
        s = _FRAMES + _PER_FRAME * i
        if not frame_rows(A[r0:r0 + m], b[r0:r0 + m], J, support[i], _matrix(at[s], 3, 3), _vector(at[s + 1], 3),
                          _matrix(at[s + 2], 3, 3), _vector(at[s + 3], 3), ix[c + 3:c + 3 + m],
                          _vector(at[s + 4], 6), fx[6 * i:6 * i + 6], e, ix[c + 2] != 0):
            return False
    c = ix[_COM_I]
    if c >= 0:                                # (first row, rows, selection); K
        r0, m = ix[c], ix[c + 1]
        s = _FRAMES + _PER_FRAME * nf
        com, com_t = _vector(at[_COM], 3), _vector(at[s], 3)
        ec = np.empty(3)
        for i in range(3):
            ec[i] = com_t[i] - com[i]
        f = ix[_COM_F]
        _motion_rows(A[r0:r0 + m], b[r0:r0 + m], _matrix(at[_JCOM], 3, nj), ix[c + 2:c + 2 + m],
                     _vector(at[s + 1], 3), fx[f:f + 3], ec)
    c = ix[_POST_I]
    if c >= 0:                                # (first row, rows, in place, q indices); K: b = K e on its unit rows
        r0, m, f = ix[c], ix[c + 1], ix[_POST_F]
        if post_e.shape[0] == m:
            for i in range(m):
                b[r0 + i] = fx[f + i] * post_e[i]
        else:                                 # e = q_d ⊖ q = q_d − q on vector-space joints (pinocchio's difference)
            q_d = _vector(at[_FRAMES + _PER_FRAME * nf + 2], q.shape[0])
            for i in range(m):
                j = ix[c + 3 + i]
                b[r0 + i] = fx[f + i] * (q_d[j] - q[j])
    c = ix[_LIM_I]
    if c >= 0:                                # (first bound, joints, their q indices); q_max, q_min, v_max
        r0, n, f = ix[c], ix[c + 1], ix[_LIM_F]
        lo, hi = _vector(at[_LO], ni), _vector(at[_HI], ni)
        _joint_velocity_bounds(lo[r0:r0 + n], hi[r0:r0 + n], q, ix[c + 2:c + 2 + n], fx[f:f + n],
                               fx[f + n:f + 2 * n], fx[f + 2 * n:f + 3 * n], margin, k)
    return True


#: pinocchio's joints whose ``difference`` is q₁ − q₀ on one coordinate (a vector space of dimension 1)
_VECTOR_JOINTS = frozenset(f"JointModel{k}{a}" for k in "RP" for a in "XYZ") | {"JointModelRevoluteUnaligned",
                                                                              "JointModelPrismaticUnaligned"}


def _vector_space_coordinates(model, idx: np.ndarray) -> list[int] | None:
    """The configuration index of each velocity index in ``idx`` when every one is a joint of one
    coordinate whose ``difference`` is the plain q₁ − q₀ (:data:`_VECTOR_JOINTS`: bounded
    revolute, prismatic), so that the posture's error q_d ⊖ q is q_d[j] − q[j] (the same
    subtraction, bit for bit); else None (its error by pinocchio, in Python)."""
    out = []
    for i in idx:
        jid = next((j for j in range(1, model.njoints) if model.idx_vs[j] <= i < model.idx_vs[j] + model.nvs[j]), 0)
        joint = model.joints[jid]
        if jid == 0 or joint.nq != 1 or joint.nv != 1 or joint.shortname() not in _VECTOR_JOINTS:
            return None
        out.append(int(model.idx_qs[jid]))
    return out


def _first_row(view: np.ndarray, base: np.ndarray) -> int:
    """The row of ``base`` where ``view`` (a block of its rows, or of its entries) starts."""
    offset = view.__array_interface__["data"][0] - base.__array_interface__["data"][0]
    step = base.strides[0]
    if offset % step or not 0 <= offset // step < max(len(base), 1):
        raise ValueError("the block is not a block of the buffer's rows")
    return offset // step


def _hold(at: np.ndarray, keep: list, slot: int, x, owner=None, size: int = 0) -> bool:
    """``at[slot]`` ← the address of x's data, x (or its ``owner``, the object x is a view of)
    kept in ``keep[slot]`` so that the address stays valid and a replaced object is seen. False
    (nothing held) when x is not float64 with its entries in the order the kernel reads them
    (a matrix of pinocchio's column-major, the buffer's A row-major, a vector contiguous) or has
    fewer than ``size`` entries."""
    ok = isinstance(x, np.ndarray) and x.dtype == np.float64 and x.size >= size
    if ok:
        ok = x.flags.f_contiguous if x.ndim == 2 and slot != _A else x.flags.c_contiguous
    if not ok:
        if slot < _FRAMES:
            raise ValueError("an array of the buffer or of pinocchio's data is not as the kernel reads it")
        keep[slot] = None
        return False
    at[slot] = x.__array_interface__["data"][0]
    keep[slot] = x if owner is None else owner
    return True


class StackWriter:
    """The covered tasks' rows in one call (:func:`stack_writer`): ``write()`` (True written, False
    plan again, None this cycle by the writers), or in two steps, :meth:`prepare` (this cycle's
    Python checks: the gains, the targets' addresses, the posture's error) then :func:`_stack_rows`
    of :attr:`held`, ``robot.q`` and what :meth:`prepare` returned (the velocity plan's call that
    also solves, :mod:`wbc.controller.velocity_step`)."""

    __slots__ = ("prepare", "held", "robot")

    def __init__(self, prepare: Callable[[], tuple | Literal[False] | None], held: tuple, robot) -> None:
        #: () -> (post_e, margin, k), the arguments of this cycle after ``held`` and q; False plan
        #: again; None this cycle by the writers
        self.prepare = prepare
        #: (at, ix, fx, support): the tables :func:`_stack_rows` reads, held for the plan's life
        self.held = held
        self.robot = robot

    def __call__(self) -> bool | None:
        got = self.prepare()
        if got is None or got is False:
            return got
        at, ix, fx, support = self.held
        return True if _stack_rows(at, ix, fx, support, self.robot.q, *got) else None


def stack_writer(writers: list[Writer], tasks: list, buffer, robot) -> tuple[StackWriter | None, list[Writer]]:
    """(write, the writers it does not cover): ``write()`` (a :class:`StackWriter`) writes the covered tasks' rows in one
    call (module docstring) and returns True, False when a task's rows changed shape (plan
    again, as a writer says), None when this cycle is for the writers (every writer is then to be
    called). ``write`` is None when no frame or contact is covered (the writers as they are).

    Covered: the point frame tasks, the contacts, at most one CoM, one posture and one
    joint-limit task, each of weight 1 (its rows straight in the buffer's blocks); the others
    (a weighted task, a collision task, the differential drive, a frame task with angular
    axes) keep their writers.

    Args:
        writers: the plan's writers, one a task, bound to the buffer's blocks.
        tasks: their tasks, in the same order.
        buffer: the :class:`~wbc.problem.buffer.RowBuffer` whose blocks they write.
        robot: the robot (its ``data`` is held, its ``q`` read each cycle).
    """
    frames, com, posture, limits, rest = [], None, None, None, []
    for w, t in zip(writers, tasks):
        spec = getattr(w, "spec", None)
        if spec is None or t.weight != 1.0:
            rest.append(w)
        elif spec[0] in ("frame", "contact"):
            frames.append(spec)
        elif spec[0] == "com" and com is None:
            com = spec
        elif spec[0] == "posture" and posture is None:
            posture = spec
        elif spec[0] == "limits" and limits is None:
            limits = spec
        else:
            rest.append(w)
    if not frames:
        return None, writers
    A, b, lo, hi, nv = buffer.A, buffer.b, buffer.lo, buffer.hi, buffer.A.shape[1]
    data = robot.data
    nf = len(frames)
    at = np.zeros(_FRAMES + _PER_FRAME * nf + 3, dtype=np.int64)
    at[:_A] = len(b), len(lo), nv, data.J.shape[1]
    keep: list = [None] * len(at)              # what each address is of, alive while it is in ``at``
    for slot, x in ((_A, A), (_B, b), (_LO, lo), (_HI, hi), (_J, data.J), (_COM, data.com[0]), (_JCOM, data.Jcom)):
        _hold(at, keep, slot, x)
    ints = [nf, -1, -1, -1, -1, -1, -1]
    floats: list = []
    gains: list[tuple] = []                    # (task, its _Gain, its slot of fx, its size)
    support = np.zeros((nf, nv), dtype=np.bool_)
    for i, s in enumerate(frames):
        task, fA, sel, K = s[1], s[2], s[7], s[8]
        row = [_first_row(fA, A), len(sel), int(s[0] == "contact" and s[9]), *sel]
        ints += row + [0] * (_FRAME_INTS - len(row))
        support[i] = s[4][:nv]
        gains.append((task, K, 6 * i, len(K.get())))
        floats += [0.0] * 6
        _hold(at, keep, _FRAMES + _PER_FRAME * i, s[5])
        _hold(at, keep, _FRAMES + _PER_FRAME * i + 1, s[6])
    contact = [s[0] == "contact" for s in frames]
    com_slot = _FRAMES + _PER_FRAME * nf
    post_slot = com_slot + 2
    post_q: list[int] | None = None
    if com is not None:
        com_task, cA, _, csel, cK, _, _, cm = com[1:]
        ints[_COM_I], ints[_COM_F] = len(ints), len(floats)
        ints += [_first_row(cA, A), cm, *csel]
        gains.append((com_task, cK, len(floats), 3))
        floats += [0.0] * 3
    if posture is not None:
        post_task, pA, _, pK, pm = posture[1:]
        ints[_POST_I], ints[_POST_F] = len(ints), len(floats)
        post_idx = post_task.coordinates(robot)
        post_q = _vector_space_coordinates(robot.model, post_idx)
        ints += [_first_row(pA, A), pm, int(post_q is not None), *(post_q or ())]
        gains.append((post_task, pK, len(floats), pm))
        floats += [0.0] * pm
    if limits is not None:
        lim_task, llo, _, qi, qmax, qmin, vmax, dt = limits[1:]
        ints[_LIM_I], ints[_LIM_F] = len(ints), len(floats)
        ints += [_first_row(llo, lo), len(qi), *qi]
        floats += [*qmax, *qmin, *vmax]
    ix, fx = np.array(ints, dtype=np.int64), np.array(floats, dtype=float)
    copied: list = [None] * len(gains)         # the kp each gain's slot of fx was copied from
    none = np.zeros(0)

    def check() -> tuple | Literal[False] | None:
        for i, (t, K, f, n) in enumerate(gains):
            if t.kp is not copied[i]:
                fx[f:f + n] = K.get()
                copied[i] = t.kp
        for i, s in enumerate(frames):         # the targets: read each cycle, their addresses when replaced
            t = s[1]
            j = _FRAMES + _PER_FRAME * i + 2
            if contact[i]:
                if t.sliding != s[10]:
                    return False
                T, v = t.reference, s[11]
            else:
                T, v = t.target, t.target_velocity
            if T is None:
                return None                    # the writer sets it (a contact's reference: its placement now)
            if T is not keep[j] and not (_hold(at, keep, j, T.rotation, T) and _hold(at, keep, j + 1, T.translation)):
                return None
            if v is not keep[j + 2] and not _hold(at, keep, j + 2, v, size=6):
                return None
        post_e = none
        if posture is not None:               # its error in the call (q_d held) where its joints allow
            if post_q is None or post_task.coordinates(robot) is not post_idx or (
                    (q_d := post_task._q_ref(robot)) is not keep[post_slot]
                    and not _hold(at, keep, post_slot, q_d, size=robot.nq)):
                post_e = post_task.error(robot)
                if len(post_e) != pm:
                    return False
        if com is not None:
            if len(com_task.axes) != cm:
                return False
            c, v = com_task.target, com_task.target_velocity
            if c is None:
                return None                    # the writer sets it (the CoM now)
            if c is not keep[com_slot] and not _hold(at, keep, com_slot, c, size=3):
                return None
            if v is not keep[com_slot + 1] and not _hold(at, keep, com_slot + 1, v, size=3):
                return None
        margin = k = 0.0
        if limits is not None:
            if lim_task.rate_limit:
                return None
            margin, k = lim_task.margin, min(1.0 / lim_task.horizon, 1.0 / dt)
        return post_e, margin, k

    passed: list = [-1, None]           # (TASK_CHANGES[0] when check() last passed whole, its answer)

    def prepare() -> tuple | Literal[False] | None:
        """check()'s answer, run again only after a task's watched attribute was assigned
        (:data:`wbc.tasks.base.TASK_CHANGES`): every attribute it reads is one, or fixed for the
        plan's life. Kept only when it passed whole with nothing computed from the state (the
        posture's error in the call, not in Python)."""
        count = TASK_CHANGES[0]
        if passed[0] == count:
            return passed[1]
        got = check()
        passed[0] = count if type(got) is tuple and got[0] is none else -1
        passed[1] = got
        return got

    return StackWriter(prepare, (at, ix, fx, support), robot), rest
