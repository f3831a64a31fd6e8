"""Convex hulls of collision meshes, cached on disk and never trusted blindly.

A mesh's distance query costs ~3 ms on its triangles (pinocchio's ``computeDistances`` on
Talos's 52 meshes: 161 ms for all pairs) and ~0.5 µs on its convex hull, so every mesh
is replaced by the hull of its vertices (coal's ``BVHModel.buildConvexHull``, qhull).
The hull's vertices are cached in ``$WBC_CACHE_DIR/hulls`` (default ``~/.cache/wbc/hulls``),
one ``.hull`` file per mesh (a text line ``key checksum n``, then n × 3 float64 vertices; no
pickle and no ``numpy.load``), named by the key ``sha256(mesh file bytes, scale, coal version,
format)``. A cached file is used only when it opens, carries the same key and the
checksum of its own vertices matches; otherwise (stale, truncated, edited) it is rebuilt
and rewritten (:func:`convex_hull`).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import coal
import numpy as np

#: bump when the cached content changes meaning
FORMAT = 2


def cache_dir() -> Path:
    """Where hulls are cached: ``$WBC_CACHE_DIR/hulls`` or ``~/.cache/wbc/hulls``."""
    root = os.environ.get("WBC_CACHE_DIR")
    return (Path(root) if root else Path.home() / ".cache" / "wbc") / "hulls"


def hull_key(mesh_path: str | Path, scale: np.ndarray) -> str:
    """sha256 of the mesh file's bytes, its scale (3 floats), coal's version and :data:`FORMAT`."""
    h = hashlib.sha256(Path(mesh_path).read_bytes())
    h.update(np.asarray(scale, dtype=float).tobytes())
    h.update(f"coal {coal.__version__} format {FORMAT}".encode())
    return h.hexdigest()


def _checksum(points: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(points, dtype=float).tobytes()).hexdigest()


def _hull_points(bvh) -> np.ndarray:
    """The vertices (n × 3, m, in the mesh's frame, scaled) of the convex hull of a coal BVH."""
    bvh.buildConvexHull(True, "Qt")
    cv = bvh.convex
    return np.array(cv.points(), dtype=float)              # (n, 3): coal deprecates points(i)


def read_cached(path: Path, key: str) -> np.ndarray | None:
    """The cached hull vertices at ``path`` if the file is whole and is for ``key``, else None."""
    try:
        raw = Path(path).read_bytes()
        head, body = raw.split(b"\n", 1)
        got_key, checksum, n = head.decode("ascii").split(" ")
        if got_key != key or len(body) != int(n) * 3 * 8:
            return None
        points = np.frombuffer(body, dtype="<f8").reshape(int(n), 3).copy()
        if checksum != _checksum(points):
            return None
    except Exception:       # a corrupt file (truncated, not ours, missing fields): rebuild it
        return None
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 4 or not np.isfinite(points).all():
        return None
    return points


def write_cached(path: Path, key: str, points: np.ndarray) -> None:
    """Write ``points`` (n × 3) for ``key`` at ``path`` atomically (a reader never sees half a file)."""
    pts = np.ascontiguousarray(points, dtype="<f8")
    tmp = Path(path).with_suffix(f".{os.getpid()}.tmp")
    tmp.write_bytes(f"{key} {_checksum(pts)} {len(pts)}\n".encode("ascii") + pts.tobytes())
    os.replace(tmp, path)


def convex_hull(bvh, mesh_path: str | Path, scale: np.ndarray, directory: Path | None = None) -> coal.Convex:
    """The convex hull of the mesh ``bvh`` (a coal BVHModel loaded from ``mesh_path`` with
    ``scale``), from the cache when a valid entry exists, else built and cached.

    Args:
        bvh: the mesh as pinocchio's URDF parser loaded it (coal ``BVHModelOBBRSS``).
        mesh_path: the mesh file (its bytes key the cache).
        scale: the mesh's scale (3,), part of the key.
        directory: the cache directory (default :func:`cache_dir`).
    """
    key = hull_key(mesh_path, scale)
    directory = cache_dir() if directory is None else Path(directory)
    path = directory / f"{key}.hull"
    points = read_cached(path, key) if path.exists() else None
    if points is None:
        points = _hull_points(bvh)
        directory.mkdir(parents=True, exist_ok=True)
        write_cached(path, key, points)
    return coal.Convex.convexHull(vec3s(points), True, "Qt")


def vec3s(points: np.ndarray):
    """``points`` (n × 3) as coal's std::vector of 3-vectors (coal 3.0's binding, with pinocchio
    3.8, takes no Python list there)."""
    out = coal.StdVec_Vec3s()
    for p in np.asarray(points, dtype=float):
        out.append(p)
    return out


def hull_vertices(geometry) -> np.ndarray:
    """Vertices (n × 3, m) whose convex hull is (or encloses) ``geometry``."""
    if isinstance(geometry, coal.ConvexBase):
        return np.asarray(geometry.points(), dtype=float).reshape(-1, 3)
    if isinstance(geometry, coal.Box):
        h = np.asarray(geometry.halfSide, dtype=float)
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    dirs = np.array([[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)],
                    dtype=float)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    if isinstance(geometry, coal.Sphere):
        return dirs * geometry.radius / np.cos(np.pi / 4) ** 2       # a shell enclosing the sphere
    if isinstance(geometry, coal.Capsule | coal.Cylinder):
        r, h = geometry.radius, geometry.halfLength
        ring = dirs[np.abs(dirs[:, 2]) < 1e-9] * r / np.cos(np.pi / 8)
        caps = ([dirs * r / np.cos(np.pi / 4) ** 2 + [0, 0, s * h] for s in (-1, 1)]
                if isinstance(geometry, coal.Capsule) else [])
        return np.vstack([ring + [0, 0, h], ring - [0, 0, h], *caps])
    raise TypeError(f"no vertices for a {type(geometry).__name__}")


def bounding_sphere(geometry) -> tuple[np.ndarray, float]:
    """(centre in the geometry's frame, radius) of a sphere enclosing ``geometry`` (m);
    infinite radius for a half-space."""
    if isinstance(geometry, coal.Halfspace):
        return np.zeros(3), np.inf
    geometry.computeLocalAABB()
    return np.array(geometry.aabb_center, dtype=float), float(geometry.aabb_radius)
