"""The convex-hull cache (wbc.collision.hulls): a stale or corrupt entry is rebuilt, never trusted."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.collision import hulls
from wbc.robot.loader import load_robot


def _mesh():
    robot = load_robot("tiago")
    gm = pin.buildGeomFromUrdf(robot.model, str(robot.urdf_path), pin.GeometryType.COLLISION, None,
                               robot.package_dirs)
    g = next(g for g in gm.geometryObjects if g.meshPath.endswith((".stl", ".STL", ".dae")))
    return g.geometry, g.meshPath, g.meshScale


def _points(cv):
    return np.array(cv.points(), dtype=float)


def test_corrupt_and_stale_entries_are_rebuilt(tmp_path):
    bvh, path, scale = _mesh()
    fresh = _points(hulls.convex_hull(bvh, path, scale, tmp_path))
    entry = tmp_path / f"{hulls.hull_key(path, scale)}.hull"
    assert entry.exists() and hulls.read_cached(entry, hulls.hull_key(path, scale)) is not None

    entry.write_bytes(entry.read_bytes()[:100])                        # truncated
    assert hulls.read_cached(entry, hulls.hull_key(path, scale)) is None
    np.testing.assert_allclose(_points(hulls.convex_hull(bvh, path, scale, tmp_path)), fresh)
    assert hulls.read_cached(entry, hulls.hull_key(path, scale)) is not None   # rewritten

    key = hulls.hull_key(path, scale)                                   # edited vertices, same key
    good = hulls.read_cached(entry, key)
    head, body = entry.read_bytes().split(b"\n", 1)
    pts = good * 2.0
    entry.write_bytes(head + b"\n" + np.ascontiguousarray(pts, dtype="<f8").tobytes())   # checksum of the old ones
    assert hulls.read_cached(entry, key) is None
    np.testing.assert_allclose(_points(hulls.convex_hull(bvh, path, scale, tmp_path)), fresh)

    # stale: an entry written for another key (another mesh file, scale or coal version) is not used
    other = hulls.hull_key(path, np.asarray(scale) * 2.0)
    assert other != key
    hulls.write_cached(entry, other, pts)
    assert hulls.read_cached(entry, key) is None
    np.testing.assert_allclose(_points(hulls.convex_hull(bvh, path, scale, tmp_path)), fresh)
