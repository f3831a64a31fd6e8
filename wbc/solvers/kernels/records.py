"""The output of a compiled cascade run, named, and the route hints a solver keeps.

A run over L levels (:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`,
:func:`~wbc.solvers.kernels.sns_run.projection_prefix`) returns two flat arrays, ints
and floats, because a numba kernel returns fixed-type arrays cheaply. This module owns
both sides of that format: the kernels write it through :func:`start_level`,
:func:`record_level` and :func:`set_calls`, and Python reads it only through
:func:`decode` (a :class:`~wbc.problem.result.LevelInfo` per level solved, a
:class:`RunLevel` for the level it stopped at), so no offset appears anywhere else.

Per level k: ints[LEVEL_INTS·k + field] for the fields ``CALL`` (index of its step among the
run's steps, −1 for none), ``ROWS``, ``DOF`` (free directions before it), ``ROUTE``,
``RANK``, ``CERTIFIED`` (QPs solved by certificate) and ``SATURATED`` (joints saturated);
floats[LEVEL_FLOATS·k + field] for ``SIGMA_MIN``, ``SIGMA_MAX``, ``LAMBDA2`` (λ² of the
damping) and ``SCALE`` (the step's scale). After the levels' floats, their R factors row
by row; after the levels' ints, the L + 1 offsets of the R factors in floats, the count of
steps taken, the saturated joints level by level, and L last.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from ...problem.result import CERTIFIED as CERTIFIED_STATUS
from ...problem.result import LevelInfo
from .factorizations import AUTO, GRAM, QR

#: entries per level in the ints and floats of a compiled run, and their fields
LEVEL_INTS = 7
CALL, ROWS, DOF, ROUTE, RANK, CERTIFIED, SATURATED = range(LEVEL_INTS)
LEVEL_FLOATS = 4
SIGMA_MIN, SIGMA_MAX, LAMBDA2, SCALE = range(LEVEL_FLOATS)


@nb.njit(cache=True)
def new_outputs(L, r_size, k0, extra):
    """(ints, floats) of a compiled run over L levels, room for ``r_size`` entries of R
    factors and ``extra`` saturated joints."""
    ints = np.zeros(LEVEL_INTS * L + L + 3 + extra, dtype=np.int64)
    floats = np.empty(LEVEL_FLOATS * L + r_size)
    ints[LEVEL_INTS * L + k0] = LEVEL_FLOATS * L
    ints[-1] = L
    return ints, floats


@nb.njit(cache=True)
def start_level(ints, floats, k, m, dof):
    """Level k's entries before it is solved: no step, scale 1."""
    ints[LEVEL_INTS * k:LEVEL_INTS * k + LEVEL_INTS] = (-1, m, dof, 0, 0, 0, 0)
    floats[LEVEL_FLOATS * k:LEVEL_FLOATS * k + LEVEL_FLOATS] = (np.inf, 0.0, 0.0, 1.0)


@nb.njit(cache=True)
def record_level(ints, floats, k, call, route, rank, smin, smax, lam2, packed, head, r_at):
    """Level k's step (its R factor, the part of ``packed`` after z and x̂, at ``r_at``);
    returns where the next R goes."""
    ints[LEVEL_INTS * k + CALL] = call
    ints[LEVEL_INTS * k + ROUTE] = route
    ints[LEVEL_INTS * k + RANK] = rank
    floats[LEVEL_FLOATS * k + SIGMA_MIN] = smin
    floats[LEVEL_FLOATS * k + SIGMA_MAX] = smax
    floats[LEVEL_FLOATS * k + LAMBDA2] = lam2
    nr = packed.shape[0] - head
    floats[r_at:r_at + nr] = packed[head:]
    return r_at + nr


@nb.njit(cache=True)
def clear_step(ints, floats, k):
    """Level k took no step after all (SNS: every direction saturated)."""
    ints[LEVEL_INTS * k + CALL] = -1
    ints[LEVEL_INTS * k + RANK] = 0
    floats[LEVEL_FLOATS * k + SIGMA_MIN] = np.inf
    floats[LEVEL_FLOATS * k + SIGMA_MAX] = 0.0
    floats[LEVEL_FLOATS * k + LAMBDA2] = 0.0


@nb.njit(cache=True)
def set_field(ints, k, field, value):
    """Level k's int ``field`` (CERTIFIED, SATURATED, ...) set to ``value``."""
    ints[LEVEL_INTS * k + field] = value


@nb.njit(cache=True)
def add_to_field(ints, k, field, value):
    ints[LEVEL_INTS * k + field] += value


@nb.njit(cache=True)
def set_scale(floats, k, s):
    floats[LEVEL_FLOATS * k + SCALE] = s


@nb.njit(cache=True)
def end_r_factors(ints, L, k, r_at):
    """Level k's R factor ends at ``r_at`` in floats."""
    ints[LEVEL_INTS * L + k + 1] = r_at


@nb.njit(cache=True)
def set_calls(ints, L, calls):
    """The run's step count so far (the caller's cascade continues from it)."""
    ints[LEVEL_INTS * L + L + 1] = calls


@nb.njit(cache=True)
def saturated_start(L):
    """Where the saturated joints' list starts in ints."""
    return LEVEL_INTS * L + L + 2


@dataclass(slots=True)
class RunLevel:
    """The level where a run stopped, decoded (what the caller needs to take its step
    over): the free directions before it, ``route`` and ``rank`` of its factorisation, and
    σ_min, σ_max, λ² of the damping."""

    dof: int
    route: int
    rank: int
    sigma_min: float
    sigma_max: float
    lambda2: float


def decode(ints: np.ndarray, floats: np.ndarray, levels: list, start: int,
           stop: int) -> tuple[list[LevelInfo], RunLevel | None, int, int]:
    """A run's (ints, floats) read once: (a :class:`LevelInfo` per level ``start`` ..
    ``stop`` − 1 it solved, ``levels[k].index`` its index; the :class:`RunLevel` of level
    ``stop`` if the run stopped at a level; the count of steps it took; the QPs it
    solved by certificate). A level's R factor is handed over as the flat view of its
    rows in ``floats`` (``LevelInfo.sigma`` reshapes it when asked)."""
    L = int(ints[-1])
    head = LEVEL_INTS * L
    iv, fv = ints[:head + L + 2].tolist(), floats[:LEVEL_FLOATS * L].tolist()
    sat_at = head + L + 2
    infos = []
    certified = 0
    for k in range(start, min(stop, L)):
        i, f = LEVEL_INTS * k, LEVEL_FLOATS * k
        n_sat, certs = iv[i + SATURATED], iv[i + CERTIFIED]
        saturated = []
        if n_sat:
            saturated = ints[sat_at:sat_at + n_sat].tolist()
            sat_at += n_sat
        certified += certs
        status = CERTIFIED_STATUS if certs else ""
        if iv[i + CALL] >= 0:
            a, b = iv[head + k], iv[head + k + 1]
            infos.append(LevelInfo(levels[k].index, iv[i + RANK], fv[f + SIGMA_MIN], fv[f + LAMBDA2], iv[i + DOF],
                                   certs > 0, status, False, saturated, fv[f + SCALE], floats[a:b] if b > a else None))
        else:
            infos.append(LevelInfo(levels[k].index, 0, np.inf, 0.0, iv[i + DOF], certs > 0, status, False, saturated,
                                   fv[f + SCALE], None))
    at = None
    if stop < L:
        i, f = LEVEL_INTS * stop, LEVEL_FLOATS * stop
        at = RunLevel(iv[i + DOF], iv[i + ROUTE], iv[i + RANK], fv[f + SIGMA_MIN], fv[f + SIGMA_MAX], fv[f + LAMBDA2])
    return infos, at, iv[head + L + 1], certified


#: cycles a level goes straight to the route it last needed before its first route is retried
HINT_RETRY = 50
#: the longest wait between two retries: a retry that needs the same route again doubles the
#: wait (50, 100, ... cycles), so a level that keeps needing it costs a retry (its refused first
#: route, ~50 µs on Talos) in a vanishing share of the cycles, not in one of every 51 (#26: 2 %
#: of the cycles, which made the p99)
HINT_RETRY_MAX = 800


def hint_table(capacity: int = 32) -> np.ndarray:
    """An empty route-hint table (rows: call index, rows, free directions, route, cycles
    left, the wait it was set to), kept by a solver across cycles (see :func:`hint_route`)."""
    return np.zeros((capacity, 6), dtype=np.int64)


@nb.njit(cache=True)
def hint_route(table, call, m, dof):
    """The route to try first for the level that is the cascade's ``call``-th step, with m
    rows over ``dof`` free directions: the one it needed last time (for the hint's wait,
    ``HINT_RETRY`` cycles doubled by each retry that needed it again up to ``HINT_RETRY_MAX``,
    counted down here), else ``AUTO`` (a retry: the wait starts over if its first route does)."""
    for h in range(table.shape[0]):
        if table[h, 5] > 0 and table[h, 0] == call and table[h, 1] == m and table[h, 2] == dof:
            if table[h, 4] > 0:
                table[h, 4] -= 1
                return table[h, 3]
            if table[h, 4] == 0:        # the hint's wait is over: a retry (-1 while it is tried)
                table[h, 4] = -1
            else:                       # the last retry's first route did: the wait starts over
                table[h, 4], table[h, 5] = 0, 0
            return AUTO
    return AUTO


@nb.njit(cache=True)
def hint_record(table, call, m, dof, path, route):
    """Remember ``route`` for that level when it is neither the route tried (``path``) nor
    the one ``AUTO`` tries first (GRAM for m ≥ dof, QR otherwise): the first route refused."""
    first = GRAM if m >= dof else QR
    if route == path or route == first:
        return
    slot = 0
    same = False
    for h in range(table.shape[0]):
        if table[h, 0] == call and table[h, 1] == m and table[h, 2] == dof:
            slot = h
            same = True
            break
        if table[h, 4] < table[slot, 4]:
            slot = h
    wait = HINT_RETRY
    if same and table[slot, 3] == route and table[slot, 4] < 0:     # a retry that needed it again
        wait = min(2 * table[slot, 5], HINT_RETRY_MAX)
    table[slot, 0] = call
    table[slot, 1] = m
    table[slot, 2] = dof
    table[slot, 3] = route
    table[slot, 4] = wait
    table[slot, 5] = wait
