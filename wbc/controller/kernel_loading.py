"""Kernels a control cycle may switch to mid-run, loaded with the first cycle's.

Numba loads (or compiles) a kernel at its first call. The first control cycle calls most of
the kernels a run needs, but not those of a branch it did not take: the torque cycle runs the
cascade with level 0 factored within its rows' profiles
(:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix_profiled`) and switches to the plain run
(:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`) only in a cycle where a level needs a
back-end QP. Loading that kernel from numba's cache takes 70-80 ms of CPU (the whole cascade is
inlined in it): ``talos_push`` spent 83 ms in its cycle 1067, the push's first QP, against a
1 ms control period, and ``wbc bench --quick``'s "levels=7 hqp" point a 40 ms p99 for its one
cycle that needed a QP (#26).

:func:`load_alternates` loads every alternate for the argument types its kernel was called with
(``Dispatcher.compile``: from the cache when there is one, compiled otherwise): the same machine
code the later call would load, so nothing of the run's results changes, only when the time is
spent (with the first cycle's, which loads or compiles the kernels anyway).

:func:`load_first` adds the torque plan's kernel (:func:`~wbc.tasks.torque_stack.load_rows_kernel`):
the plan is made in the second cycle (after the tasks filled the row buffer in the first) and
first runs in the third, which loaded it then, 12-22 ms in a 1 ms period in every torque scenario.

:func:`load_plain_run` loads the plain run for the arguments the solver passes it after the torque
cycle's profiled run, made inside a compiled call (:mod:`wbc.controller.torque_step`), stopped:
that call leaves no signature of ``cascade_prefix_profiled`` for :func:`load_alternates` to read;
:func:`load_outputs` the torques' kernel, which that call runs inside itself on the cycles that
solve every level, for the first cycle that stops for a back-end QP.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.controller.torques import cycle_outputs
from wbc.solvers.kernels.cascade_run import cascade_prefix, cascade_prefix_profiled
from wbc.tasks.torque_stack import load_rows_kernel

#: (a kernel the first cycle calls, the kernels taking the same arguments a later cycle may
#: switch to)
ALTERNATES = ((cascade_prefix_profiled, (cascade_prefix,)),)


def load_alternates() -> int:
    """Load each of :data:`ALTERNATES`' alternates for every signature its kernel has been
    called with; returns the number of (kernel, signature) pairs loaded now (0: all were)."""
    loaded = 0
    for kernel, alternates in ALTERNATES:
        for sig in kernel.signatures:
            for alt in alternates:
                if sig not in alt.signatures:
                    alt.compile(sig)
                    loaded += 1
    return loaded


def load_first(q: np.ndarray, v: np.ndarray, h: np.ndarray) -> int:
    """What the torque cycle's first accepted cycle loads for the later ones: :func:`load_alternates`
    and the torque plan's kernel for this q, v, h (``RobotModel.h``); the number loaded now."""
    return load_alternates() + int(load_rows_kernel(q, v, h))


def load_plain_run(args: tuple) -> bool:
    """Load :func:`~wbc.solvers.kernels.cascade_run.cascade_prefix` for the types of ``args`` (its
    five arguments as the solver passes them, ``PlannedEntry.profiled_result``), from numba's cache or
    compiled; False: it was loaded. :class:`~wbc.controller.torque_step.ProfiledStep` calls it when it
    builds its tables (the first cycle, and after a change of the solver's planned arrays)."""
    sig = tuple(nb.typeof(a) for a in args)
    if sig in cascade_prefix.signatures:
        return False
    cascade_prefix.compile(sig)
    return True


def load_outputs(torques: tuple, x: np.ndarray, rows) -> bool:
    """Load :func:`~wbc.controller.torques.cycle_outputs` for the types of its arguments in the torque
    cycle (``torques`` = (M, h, J_f, unactuated, actuated, τ_max, tol) as
    :meth:`~wbc.controller.torque_step.ProfiledStep.solve_outputs` takes them, x like ``x``, the rows
    ``rows``' arrays), from numba's cache or compiled; False: it was loaded. The cycle calls it only
    where the hqp's run stops for a back-end QP (else its outputs come from the run's call)."""
    M, h, Jf, unactuated, actuated, tau_max, tol = torques
    sig = tuple(nb.typeof(a) for a in (M, h, Jf, x, unactuated, rows.A, rows.b, rows.C, rows.lo, rows.hi, actuated,
                                       tau_max, tol))
    if sig in cycle_outputs.signatures:
        return False
    cycle_outputs.compile(sig)
    return True
