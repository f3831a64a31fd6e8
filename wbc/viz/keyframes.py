"""Fewer keyframes in a recorded animation, the replay unchanged within a tolerance.

A replay's player interpolates linearly between keys (a quaternion track spherically, which
matches the linear interpolation of its components to second order in the angle between
keys). :func:`thin_track` keeps a track's first and last key and, between them, only the keys
that linear interpolation between the kept neighbours would miss by more than ``tol`` in any
component: a link that barely moves (Talos's legs while the hands reach) keeps a handful of
keys instead of one per frame. Boolean tracks (``visible``) are stepped, not interpolated:
they keep every key at which the value changes (and the first and last).
"""

from __future__ import annotations

import numpy as np

#: per component: m for positions, unitless for quaternions and scales
TOLERANCE = {"position": 1e-4, "quaternion": 1e-4, "scale": 1e-4}


def keep_mask(times: np.ndarray, values: np.ndarray, tol: float) -> np.ndarray:
    """Which keys to keep (a bool per key): greedy, each kept key the last one from which the
    straight line to the next candidate stays within ``tol`` of every key between them.

    Args:
        times: (n,) key times (any unit, increasing).
        values: (n, d) key values.
        tol: the largest interpolation error allowed, per component.
    """
    n = len(times)
    keep = np.zeros(n, bool)
    if n == 0:
        return keep
    keep[0] = keep[-1] = True
    a = 0
    j = 2
    while j < n:
        s = (times[a + 1:j] - times[a]) / (times[j] - times[a])
        line = values[a] + s[:, None] * (values[j] - values[a])
        if np.abs(line - values[a + 1:j]).max() > tol:
            a = j - 1
            keep[a] = True
        j += 1
    return keep


def thin_track(track) -> int:
    """Thin a meshcat ``AnimationTrack`` in place (module docstring); returns the keys dropped."""
    n = len(track.frames)
    if n < 3:
        return 0
    if track.jstype == "boolean":
        v = list(track.values)
        keep = [i for i in range(n) if i in (0, n - 1) or v[i] != v[i - 1]]
    else:
        tol = TOLERANCE.get(track.name.lstrip("."), 1e-4)
        mask = keep_mask(np.asarray(track.frames, float), np.asarray(track.values, float).reshape(n, -1), tol)
        keep = list(np.flatnonzero(mask))
    track.frames = [track.frames[i] for i in keep]
    track.values = [track.values[i] for i in keep]
    return n - len(keep)


def thin_animation(anim) -> tuple[int, int]:
    """Thin every track of a meshcat ``Animation`` in place; returns (keys dropped, keys before)."""
    dropped = total = 0
    for clip in anim.clips.values():
        for track in clip.tracks.values():
            total += len(track.frames)
            dropped += thin_track(track)
    return dropped, total
