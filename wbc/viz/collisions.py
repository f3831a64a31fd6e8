"""The collision task's witness segments in the meshcat view (:class:`wbc.viz.scene.Scene`), live and in
a recording.

A recording's frames hold transforms and properties, not new objects, so each of the ``count`` closest
pairs has a fixed slot ``collision/<task>/<slot>``: a group placed per frame (position, rotation and an
x scale = the segment's length, over a unit segment from the origin along x) and hidden when the slot
has no pair, and under it one unit segment per colour bin (``c0`` … ``c{BINS−1}``), of which the frame's
bin alone is visible. The distance's colour is thus stepped into :data:`BINS` bins between d_s and d_i
(the live page's colour at each bin's centre, :func:`witness_color`); the replay's player steps the
booleans and interpolates the pose between frames.
"""

from __future__ import annotations

import numpy as np

from .meshcat_quiet import mg

#: the closest pairs drawn
COUNT = 5
#: colour bins between d_s and d_i (bin 0: at or below d_s + (d_i − d_s)/BINS)
BINS = 6
#: the shortest segment drawn (m): a pair in contact keeps a visible stub along its normal
MIN_LENGTH = 1e-3


def witness_color(d: float, safety: float, influence: float) -> int:
    """0xRRGG00 for a distance d (m): red at or below the safety distance, yellow half way,
    green at the influence distance."""
    u = float(np.clip((d - safety) / (influence - safety), 0.0, 1.0))
    r, g = (1.0, 2 * u) if u < 0.5 else (2 * (1 - u), 1.0)
    return (int(255 * r) << 16) | (int(255 * min(g, 1.0)) << 8)


def color_bin(d: float, safety: float, influence: float) -> int:
    """The bin (0 … BINS − 1) of a distance d (m): u = (d − d_s)/(d_i − d_s) clipped to [0, 1)."""
    u = float(np.clip((d - safety) / (influence - safety), 0.0, 1.0 - 1e-9))
    return int(u * BINS)


def bin_color(b: int, safety: float, influence: float) -> int:
    """The colour of bin ``b``: :func:`witness_color` at the bin's centre distance."""
    return witness_color(safety + (b + 0.5) / BINS * (influence - safety), safety, influence)


def slot_path(task, slot: int) -> str:
    """The meshcat path of a task's ``slot``-th witness segment."""
    return f"collision/{task.name}/{slot}"


def add_witness_nodes(vis, task, count: int = COUNT) -> str:
    """The fixed objects of a collision task's ``count`` slots (module docstring) in the meshcat
    visualizer ``vis``: per slot and bin a unit segment (0, 0, 0)–(1, 0, 0) of the bin's colour.
    Returns the task's name."""
    unit = np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]], dtype=np.float32)
    for slot in range(count):
        for b in range(BINS):
            vis[f"{slot_path(task, slot)}/c{b}"].set_object(mg.Line(mg.PointsGeometry(unit), mg.LineBasicMaterial(
                color=bin_color(b, task.safety, task.influence), linewidth=4)))
    return task.name


def segment_pose(p1: np.ndarray, p2: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, list[float]]:
    """(rigid transform T, scale) that carry the unit segment along x onto p₁–p₂ (m, world): T's x
    axis along p₂ − p₁ (along ``normal`` when they coincide), scale (‖p₂ − p₁‖, 1, 1), at least
    :data:`MIN_LENGTH`."""
    v = np.asarray(p2, float) - np.asarray(p1, float)
    length = float(np.linalg.norm(v))
    x = v / length if length > 1e-9 else np.asarray(normal, float) / max(float(np.linalg.norm(normal)), 1e-12)
    a = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    y = np.cross(a, x)
    y /= np.linalg.norm(y)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, np.cross(x, y), p1
    return T, [max(length, MIN_LENGTH), 1.0, 1.0]


def witness_slots(task, count: int = COUNT) -> list[tuple[np.ndarray, list[float], int] | None]:
    """Per slot, the closest pairs of a collision task's last cycle
    (:attr:`wbc.tasks.CollisionAvoidance.last`, nearest first) as (T, scale, colour bin) of
    :func:`segment_pose` and :func:`color_bin`; None for a slot without a pair (pairs beyond the
    influence distance have no row and are not drawn)."""
    last = task.last
    rows, order = (None, []) if last is None else last
    out: list[tuple[np.ndarray, list[float], int] | None] = []
    for slot in range(count):
        if slot >= len(order):
            out.append(None)
            continue
        i = order[slot]
        T, scale = segment_pose(rows.p1[i], rows.p2[i], rows.normal[i])
        out.append((T, scale, color_bin(float(rows.d[i]), task.safety, task.influence)))
    return out


def draw_witness_slots(task, place, hide, show, count: int = COUNT) -> None:
    """Draw a collision task's slots (module docstring) through a scene's callbacks:
    ``place(path, T, scale)`` a slot's group, ``hide(path)`` a slot without a pair, and
    ``show(path, visible)`` each of its colour bins' segments (the distance's bin alone visible)."""
    for slot, drawn in enumerate(witness_slots(task, count)):
        path = slot_path(task, slot)
        if drawn is None:
            hide(path)
            continue
        T, scale, b = drawn
        place(path, T, scale)
        for j in range(BINS):
            show(f"{path}/c{j}", j == b)
