"""The robot's visual meshes as plain arrays, for both views.

:func:`geometry_mesh` reads one visual geometry object of a ``pinocchio.GeometryModel`` (its mesh
file through trimesh, or its box/cylinder/sphere) into vertices (m, the URDF's mesh scale applied,
a mirrored scale keeping the faces outward) and faces. :func:`cluster` thins a mesh for a replay
by vertex clustering: vertices in one ``cell``-sized cube merge into their mean and the faces that
collapse are dropped (Talos's 159 k triangles: about 140 k at 3 mm, the shape unchanged at a
viewer's distance). Each array goes into a page once, never per frame.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pinocchio as pin


def geometry_mesh(go) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices (float32, m), faces (uint32)) of a visual geometry object; None for a shape
    neither a mesh file nor a box, cylinder or sphere."""
    import trimesh

    mesh: Any
    shape = type(go.geometry).__name__
    if go.meshPath and shape.startswith("BVH"):
        with warnings.catch_warnings():
            # pycollada 0.9 (trimesh's COLLADA reader) sets ndarray.shape, deprecated in NumPy 2.5: its
            # warnings, one per triangle set, not ours (the meshes read the same)
            warnings.filterwarnings("ignore", "Setting the shape on a NumPy array", DeprecationWarning, r"collada(\.|$)")
            mesh = trimesh.load(go.meshPath, force="mesh")
    elif shape == "Box":
        mesh = trimesh.creation.box(extents=2.0 * np.asarray(go.geometry.halfSide))
    elif shape == "Cylinder":
        mesh = trimesh.creation.cylinder(radius=go.geometry.radius, height=2.0 * go.geometry.halfLength)
    elif shape == "Sphere":
        mesh = trimesh.creation.icosphere(radius=go.geometry.radius)
    else:
        return None
    scale = np.asarray(go.meshScale, dtype=np.float64) if go.meshPath and shape.startswith("BVH") else np.ones(3)
    v = np.asarray(mesh.vertices, dtype=np.float64) * scale
    f = np.asarray(mesh.faces, np.int64)
    if np.prod(scale) < 0:          # mirrored: reverse the winding, the faces stay outward
        f = f[:, ::-1]
    return v.astype(np.float32), np.ascontiguousarray(f, dtype=np.uint32)


def cluster(vertices: np.ndarray, faces: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering on a grid of ``cell`` m: (vertices, faces) with the collapsed faces gone.

    Args:
        vertices: (n, 3) positions, m.
        faces: (m, 3) vertex indices.
        cell: the grid's cell size, m (0: the mesh unchanged).
    """
    if cell <= 0:
        return vertices, faces
    key = np.floor(np.asarray(vertices, dtype=np.float64) / cell).astype(np.int64)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    merged = np.zeros((counts.size, 3))
    np.add.at(merged, inverse, vertices)
    merged /= counts[:, None]
    f = inverse[faces]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return merged.astype(np.float32), np.ascontiguousarray(f[keep], dtype=np.uint32)


def visual_model(robot) -> pin.GeometryModel:
    """Visual geometry matching ``robot.model`` (locked joints removed as in the robot YAML)."""
    root = {"free_flyer": pin.JointModelFreeFlyer(), "planar": pin.JointModelPlanar()}.get(robot.root)
    urdf = str(robot.urdf_path)
    full = pin.buildModelFromUrdf(urdf, root) if root is not None else pin.buildModelFromUrdf(urdf)
    geom = pin.buildGeomFromUrdf(full, urdf, pin.GeometryType.VISUAL, package_dirs=robot.package_dirs)
    if robot.locked_joints:
        ids = [full.getJointId(j) for j in robot.locked_joints]
        _, geom = pin.buildReducedModel(full, geom, ids, pin.neutral(full))
    return geom
