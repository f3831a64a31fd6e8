"""The route hints' wait (:func:`wbc.solvers.kernels.records.hint_route`, ``hint_record``): a level
whose first route is refused goes straight to the route it needed for ``HINT_RETRY`` cycles, then
retries its first route; each retry that needs the same route again doubles the wait, up to
``HINT_RETRY_MAX``. A retry costs the refused first route (~50 µs on Talos): at one cycle in 51 it
was 2 % of ``talos_reach``'s cycles, and set its p99 (#26). The cascade's result is the same
either way (the route is chosen only among those that prove what the SVD would decide).

The protocol is the cascade run's (:mod:`wbc.solvers.kernels.cascade_run`): ``hint_route`` gives
the route to try first; after the level is solved, ``hint_record(path, route)`` with the route
tried and the one that did."""

from __future__ import annotations

from wbc.solvers.kernels.factorizations import AUTO, GRAM, SVD
from wbc.solvers.kernels.records import HINT_RETRY, HINT_RETRY_MAX, hint_record, hint_route, hint_table

CALL, M, DOF = 2, 40, 10       # a tall level: AUTO tries GRAM first


def _cycles(table, n: int, needs_svd) -> list[int]:
    """Run n cycles of one level; ``needs_svd(k)``: whether GRAM is refused in cycle k. Returns
    the cycles that tried the first route (AUTO)."""
    tried = []
    for k in range(n):
        path = hint_route(table, CALL, M, DOF)
        if path == AUTO:
            tried.append(k)
            hint_record(table, CALL, M, DOF, AUTO, SVD if needs_svd(k) else GRAM)
        else:
            assert path == SVD
            hint_record(table, CALL, M, DOF, SVD, SVD)
    return tried


def test_a_level_that_keeps_needing_its_route_is_retried_ever_less_often():
    tried = _cycles(hint_table(), 6000, lambda k: True)
    # the first retry after HINT_RETRY hinted cycles, then the wait doubles up to HINT_RETRY_MAX
    assert tried[:3] == [0, HINT_RETRY + 1, 3 * HINT_RETRY + 2]
    gaps = [b - a - 1 for a, b in zip(tried, tried[1:])]
    assert max(gaps) == HINT_RETRY_MAX
    assert len(tried) <= 12 < 6000 // (HINT_RETRY + 1)      # not one cycle in 51


def test_the_wait_starts_over_when_a_retry_finds_the_first_route_again():
    table = hint_table()
    # needs SVD until cycle 400, not in 400-1999 (the retries find GRAM), again from 2000 on
    tried = _cycles(table, 2400, lambda k: k < 400 or k >= 2000)
    again = [k for k in tried if k >= 2000]
    # the first cycle that needs it had no hint in force; its wait is HINT_RETRY again, not the doubled one
    assert again[:2] == [2000, 2000 + HINT_RETRY + 1]
    # between the two periods every cycle tried GRAM first (no hint kept in force)
    assert all(k in tried for k in range(1000, 2000))
