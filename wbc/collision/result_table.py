"""coal's distance results of one GeometryData as one table held once: every pair's d, n and p₁
read without a crossing of the bindings.

pinocchio keeps a GeometryData's results in one vector of coal ``DistanceResult`` (one per pair, one
after the other, written in place by every ``computeDistances``), and coal's bindings give each
result's ``normal`` as a view on that storage. :func:`result_table` spans the vector with one
(pairs × 7) view, a row per pair: [d, n (3), p₁ (3)] (m; ``min_distance``, ``normal`` and the first
of ``nearest_points``, which coal stores next to each other). Reading the ~30 near pairs' rows is
then one indexing, where the bindings cost ~0.5-1 µs an attribute a pair (~86 reads, ~60-105 µs
a cycle, ``benchmarks/collisions.md``).

Nothing is assumed unchecked: the normal's place is every result's own view (its address and
strides, checked pair by pair here), and d's and p₁'s places next to it are accepted only after
:meth:`ResultTable.confirm` found them bit for bit equal to the bindings' own reads
(``min_distance``, ``getNearestPoint1()``, ``normal``) on a real pass; until then, or if they
differ (another coal build), :attr:`ResultTable.rows` is None and the caller reads the proxies.
"""

from __future__ import annotations

import ctypes

import numpy as np

__all__ = ["ResultTable", "proxy_rows", "result_table"]

#: where d sits in a DistanceResult relative to its normal (bytes), the row being the 7 doubles from there: d, n, p₁
#: (confirmed on a real pass, :meth:`ResultTable.confirm`)
_D_OFFSET = -8


class ResultTable:
    """The (pairs × 7) view of a GeometryData's distance results, [d, n, p₁] per pair (module docstring).

    Args:
        results: the results' proxies, one per pair, in pair order (:meth:`CollisionModel.results`).
    """

    def __init__(self, results: list) -> None:
        self.results = results                      # keeps the proxies (and their GeometryData) alive
        #: the table, once :meth:`confirm` has checked it; None: read the proxies
        self.rows: np.ndarray | None = None
        self._candidate: np.ndarray | None = None
        self.failed = False
        if len(results) < 1:
            return
        normals = [r.normal for r in results]
        first = normals[0]
        if first.flags.owndata or first.dtype != np.float64 or first.strides != (8,):
            return
        base = first.__array_interface__["data"][0]
        stride = normals[1].__array_interface__["data"][0] - base if len(normals) > 1 else 0
        if len(normals) > 1 and (stride < 7 * 8 or stride % 8):
            return
        for k, n in enumerate(normals):
            if n.flags.owndata or n.strides != (8,) or n.__array_interface__["data"][0] != base + k * stride:
                return
        start = base + _D_OFFSET
        span = (len(results) - 1) * stride + 7 * 8
        buf = (ctypes.c_char * span).from_address(start)
        flat = np.frombuffer(memoryview(buf), dtype=np.float64, count=span // 8)
        self._candidate = np.lib.stride_tricks.as_strided(flat, shape=(len(results), 7), strides=(stride, 8),
                                                          writeable=False)

    def confirm(self, ks: np.ndarray | list[int]) -> None:
        """After a ``computeDistances`` that computed the pairs ``ks``: keep the table if its rows of those pairs are the
        bindings' own reads bit for bit (d, n, p₁), else give it up for good."""
        if self.rows is not None or self._candidate is None or self.failed or len(ks) == 0:
            return
        T = self._candidate
        for k in list(ks):
            r = self.results[int(k)]
            got = T[int(k)]
            want = np.concatenate([[r.min_distance], np.asarray(r.normal), np.asarray(r.getNearestPoint1())])
            if not (np.array_equal(got, want) and np.isfinite(want).all()):
                self.failed = True
                self._candidate = None
                return
        self.rows = T


def result_table(results: list) -> ResultTable:
    """The :class:`ResultTable` of one GeometryData's results' proxies (pair order).

    Args:
        results: one coal ``DistanceResult`` proxy per pair.
    """
    return ResultTable(results)


def proxy_rows(results: list, ks: np.ndarray) -> np.ndarray:
    """The table's rows [d, n, p₁] (k × 7, m) of the pairs ``ks`` read through the bindings instead (where no table is
    confirmed): coal's ``min_distance``, ``normal``, ``getNearestPoint1()``.

    Args:
        results: one coal ``DistanceResult`` proxy per pair.
        ks: the pairs (k,).
    """
    out = np.empty((len(ks), 7))
    for i, k in enumerate(ks.tolist()):
        r = results[k]
        out[i, 0] = r.min_distance
        out[i, 1:4] = r.normal
        out[i, 4:7] = r.getNearestPoint1()
    return out
