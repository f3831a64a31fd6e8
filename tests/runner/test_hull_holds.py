"""The support polygon's hull kept by its certificate (:func:`wbc.runner.state_kernel.hull_holds`)
instead of a Qhull call every ``refresh`` cycles: the certificate holds only where Qhull would give
the same vertices, and the margin a run reads is the one a fresh hull gives."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from wbc.runner import metrics
from wbc.runner.metrics import HULL_TOL, SupportPolygon
from wbc.runner.state_kernel import hull_holds, polygon_margin


def _rotated_to(v: np.ndarray, first: int) -> list[int]:
    """v's cycle started at its entry ``first`` (Qhull's start is its own)."""
    k = int(np.flatnonzero(v == first)[0])
    return np.r_[v[k:], v[:k]].tolist()


def test_the_certificate_holds_exactly_where_qhull_keeps_the_vertices():
    """Two feet's 8 corners (two 0.2 × 0.1 m rectangles) moved a little at random, many times:
    wherever the certificate holds for the first hull's vertices, Qhull on the moved points gives
    those vertices in the same cyclic order; and it does hold for most small moves (else it saves
    nothing) and fails for some (points crossing an edge's line)."""
    rng = np.random.default_rng(7)
    foot = np.array([[0.1, 0.05], [0.1, -0.05], [-0.1, -0.05], [-0.1, 0.05]])
    base = np.vstack([foot + [0.0, 0.1], foot + [0.02, -0.1]])
    P0 = np.c_[base, np.zeros(8)]
    idx = np.arange(8, dtype=np.int64)
    verts = idx[ConvexHull(P0[:, :2]).vertices]
    held = failed = 0
    for scale in (1e-4, 1e-3, 1e-2, 3e-2):
        for _ in range(300):
            P = P0 + np.c_[scale * rng.standard_normal((8, 2)), np.zeros(8)]
            fresh = idx[ConvexHull(P[:, :2]).vertices]
            if hull_holds(P, idx, verts, HULL_TOL):
                held += 1
                assert len(fresh) == len(verts) and _rotated_to(fresh, verts[0]) == verts.tolist()
                assert polygon_margin(P, verts, 0.01, 0.0) == polygon_margin(P, fresh, 0.01, 0.0)
            else:
                failed += 1
    assert held > 300 and failed > 100


def test_a_point_on_an_edge_or_outside_fails_the_certificate():
    """A square's vertices with a fifth point inside, then on an edge, then outside it; and a
    polygon given clockwise (not the hull's counter-clockwise order)."""
    sq = np.array([[0.0, 0.0, 0], [1.0, 0.0, 0], [1.0, 1.0, 0], [0.0, 1.0, 0], [0.5, 0.5, 0]])
    idx = np.arange(5, dtype=np.int64)
    verts = np.array([0, 1, 2, 3], dtype=np.int64)
    assert hull_holds(sq, idx, verts, HULL_TOL)
    for y in (0.0, -1e-3, 0.5e-9):
        P = sq.copy()
        P[4, 1] = y
        assert not hull_holds(P, idx, verts, HULL_TOL)
    assert not hull_holds(sq, idx, verts[::-1].copy(), HULL_TOL)
    P = sq.copy()
    P[4, 0] = np.nan
    assert not hull_holds(P, idx, verts, HULL_TOL)


def test_the_refresh_calls_qhull_only_when_the_hull_changed(monkeypatch):
    """:class:`SupportPolygon` every ``refresh`` cycles: the points unchanged, no Qhull call and
    the same vertices; a point moved outside the polygon, Qhull again and the new vertices."""
    calls = []
    real = metrics.ConvexHull

    def counted(xy):
        calls.append(1)
        return real(xy)

    monkeypatch.setattr(metrics, "ConvexHull", counted)
    P = np.array([[0.0, 0.0, 0], [1.0, 0.0, 0], [1.0, 1.0, 0], [0.0, 1.0, 0], [0.5, 0.5, 0]])
    idx = np.arange(5, dtype=np.int64)
    hull = SupportPolygon(refresh=3)
    first = hull.vertices((0, 1, 2, 3, 4), idx, P)
    for _ in range(10):
        hull.counted(True)
        assert hull.vertices((0, 1, 2, 3, 4), idx, P).tolist() == first.tolist()
    assert len(calls) == 1
    P[4] = [2.0, 0.5, 0]
    for _ in range(3):
        hull.counted(True)
        v = hull.vertices((0, 1, 2, 3, 4), idx, P)
    assert len(calls) == 2 and sorted(v.tolist()) == [0, 1, 2, 3, 4]     # (2, 0.5) a vertex now
