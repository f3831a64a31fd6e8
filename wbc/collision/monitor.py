"""CollisionMonitor: the distances of every monitored pair on a state, cycle after cycle.

What a run reports of its collision avoidance, measured on the simulator's true state after
each step (not on the controller's model of the measured one), on **every** monitored pair of
the :class:`~wbc.collision.model.CollisionModel` (not only the pairs its broad phase kept):

- ``collision_distance_min`` (m): the smallest distance over every pair and every cycle
  (< 0: penetration depth);
- ``collision_closest_pair``: the two geometry names of that pair, and when (``collision_closest``:
  time in s, and the five closest pairs of that cycle with their distances);
- ``collision_pairs_active_max``: the most pairs within the influence distance in one cycle
  (the rows the task used), and ``collision_rows_binding_max``: the most of those rows at their
  bound (the damper braking) in one cycle.

A pair already closer than the safety distance when the monitoring starts is a warning
(:meth:`CollisionMonitor.start_warnings`) naming it and its penetration or gap.
"""

from __future__ import annotations

import numpy as np


class CollisionMonitor:
    """Every monitored pair's distance on the true state (module docstring).

    Args:
        model: the :class:`~wbc.collision.model.CollisionModel` (its pairs are monitored).
        safety: d_s (m), for the start warnings.
        influence: d_i (m), for the per-cycle count of pairs within it.
    """

    def __init__(self, model, safety: float, influence: float) -> None:
        self.model, self.safety, self.influence = model, float(safety), float(influence)
        self.data = model.robot.model.createData()
        self.gdata = model.new_geometry_data()
        self.d_min = np.inf
        self.closest_k = -1
        self.closest_t = np.nan
        self.closest_list: list[tuple[str, float]] = []
        self.pairs_active_max = 0
        self.rows_binding_max = 0
        self.cycles = 0
        self.last: tuple[np.ndarray, np.ndarray] | None = None   # the last cycle's 5 smallest (d, pairs)

    def distances(self, q: np.ndarray) -> np.ndarray:
        """Every monitored pair's distance at ``q`` (m), in the monitor's own data."""
        return self.model.all_distances(q, self.data, self.gdata)

    def record(self, t: float, q: np.ndarray, rows_in_use: int = 0, rows_binding: int = 0) -> float:
        """One cycle: the five smallest distances over every pair at the true state ``q`` (exact:
        :meth:`~wbc.collision.model.CollisionModel.smallest_distances`), and the task's rows in
        use and at their bound this cycle. Returns this cycle's smallest distance (m)."""
        self.cycles += 1
        self.pairs_active_max = max(self.pairs_active_max, int(rows_in_use))
        self.rows_binding_max = max(self.rows_binding_max, int(rows_binding))
        if not len(self.model.pairs):
            return np.inf
        d, ks = self.model.smallest_distances(q, 5, self.data, self.gdata)
        self.last = (d, ks)
        if d[0] < self.d_min:
            self.d_min, self.closest_k, self.closest_t = float(d[0]), int(ks[0]), float(t)
            self.closest_list = [(self.model.pair_name(int(k)), float(x)) for x, k in zip(d, ks)]
        return float(d[0])

    def witness_segments(self, count: int = 5) -> list[tuple[str, float, np.ndarray, np.ndarray]]:
        """The closest pairs of the last :meth:`record` (at most 5: name, d in m, p1, p2 world
        witness points in m), closest first: what a viewer draws."""
        if self.last is None:
            return []
        out = []
        for k in self.last[1][:count]:
            d, p1, p2, _ = self.model.witness_of(int(k), self.gdata)
            out.append((self.model.pair_name(int(k)), d, p1, p2))
        return out

    def start_warnings(self, q: np.ndarray) -> list[str]:
        """One message per pair closer than the safety distance at ``q``: a robot that starts in
        (or too near) a collision; the controller's damper pushes it out (its rows ask d̈ > 0 there)."""
        d = self.distances(q)
        out = []
        for k in np.argsort(d):
            if d[k] >= self.safety:
                break
            what = f"penetration {-d[k] * 1e3:.1f} mm" if d[k] < 0 else f"gap {d[k] * 1e3:.1f} mm"
            out.append(f"starts in collision: pair {self.model.pair_name(int(k))}: {what} (safety distance "
                       f"{self.safety * 1e3:.1f} mm); the collision task pushes it out")
        return out

    def summary(self) -> dict:
        """The run's collision metrics (module docstring); empty when nothing was recorded."""
        if not self.cycles:
            return {}
        if self.closest_k < 0:
            return {"collision_distance_min": None, "collision_closest_pair": None,
                    "collision_pairs_active_max": self.pairs_active_max,
                    "collision_rows_binding_max": self.rows_binding_max}
        a, b = self.model.pairs[self.closest_k]
        return {"collision_distance_min": self.d_min,
                "collision_closest_pair": [self.model.names[a], self.model.names[b]],
                "collision_pairs_active_max": self.pairs_active_max,
                "collision_rows_binding_max": self.rows_binding_max,
                "collision_closest": {"time": self.closest_t, "pairs": [[n, d] for n, d in self.closest_list]}}
