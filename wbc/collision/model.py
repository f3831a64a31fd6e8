"""CollisionModel: the robot's collision geometry (pinocchio GeometryModel, coal), its monitored pairs, a broad phase,
and the distance rows of the near pairs, once per cycle.

Geometry: the URDF's ``<collision>`` elements (``pin.buildGeomFromUrdf``), each mesh replaced by its convex hull
(:mod:`wbc.collision.hulls`), or, opted in (``primitives=True``), by the capsule, box or sphere that the robot's
collision file gives it (:mod:`wbc.collision.primitives`), plus fixed obstacles (:mod:`wbc.collision.shapes`)
attached to the universe.

Pairs: self pairs (every pair of robot geometries, minus the SRDF's disabled pairs, minus geometries on one joint or
on adjacent joints; or the list ``wbc robot collisions ROBOT`` wrote beside the robot YAML,
:mod:`wbc.collision.pairs`), plus each obstacle against the robot geometries of the chosen links.

Per cycle (:meth:`CollisionModel.distance_rows`), from the joint placements that ``RobotModel.update`` computed
(nothing is recomputed when asked twice in one cycle):

1. broad phase: each pair's last exact distance d₀ minus a bound on how far the joints moved its two geometries since
   (:func:`wbc.collision.motion.motion_weights`, accumulated cycle to cycle from ``pin.difference``); a pair is *near*
   when that lower bound is < d_i (exact: a pair left out is farther; a pair never computed is near). The monitor's
   :meth:`CollisionModel.smallest_distances` orders pairs by their bounding spheres instead (centre c, radius ρ in the
   joint's frame: ‖c₁ − c₂‖ − ρ₁ − ρ₂ ≤ d; a plane: its signed distance to c minus ρ);
2. exact phase: coal's distance on the near pairs only: d, witness points p₁ (on the first geometry) and p₂, normal n
   = (p₂ − p₁)/‖p₂ − p₁‖ (coal's, from 1 to 2; it stays defined in penetration, d < 0), read as one held table
   (:mod:`wbc.collision.result_table`), the pairs that changed activated one by one;
3. the distance Jacobian J_d = nᵀ (J_p₂ − J_p₁) (1 × nv), J_p the world-aligned Jacobian of the point of the
   geometry's joint at the witness point, J_p = J_v − [p − o]× J_ω; and the drift J̇_d q̇: the distance's second
   difference (default; with ``switch_jump`` ḋ's jump at a feature switch ahead too), the closest features' local
   model (``analytic_drift``) or the witness points' rigid drift (:mod:`wbc.collision.drift`).

The result is level-independent (:class:`DistanceRows`): the acceleration-level row reads J_d q̈ ≥ d̈_min − J̇_d q̇, a
velocity-level row J_d q̇ ≥ ḋ_min.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from ..errors import RobotDefinitionError
from .drift import curvature_drift, rigid_drift, switch_jump
from .hulls import bounding_sphere, convex_hull, hull_vertices
from .motion import motion_weights
from .nearest import bounds_at, broad_gaps, smallest_distances
from .result_table import ResultTable, proxy_rows
from .row_kernels import broad_phase, held_near_rows, masked_pair_sum, near_rows, toggles, weight_spans
from .shapes import Obstacle
from .step import step_scale


@dataclass(slots=True)
class DistanceRows:
    """The near pairs of one cycle, level-independent (:mod:`wbc.collision.model`).

    ``pairs`` (k,) indices into :attr:`CollisionModel.pairs`; ``d`` (k,) distances (m, < 0 in penetration); ``d_dot``
    (k,) ḋ = J_d q̇ (m/s); ``J`` (k × nv) distance Jacobians (m per unit of q̇); ``drift`` (k,) J̇_d q̇ (m/s²);
    ``normal`` (k × 3) unit normals from 1 to 2; ``p1``, ``p2`` (k × 3) witness points (m, world); with
    ``switch_jump`` (else None): ``jump`` (k,) ḋ's jumps at feature switches ahead (m/s), ``local`` (k,) the pieces' J̇_d q̇."""

    pairs: np.ndarray
    d: np.ndarray
    d_dot: np.ndarray
    J: np.ndarray
    drift: np.ndarray
    normal: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    jump: np.ndarray | None = None
    local: np.ndarray | None = None


#: at most this many pairs switched one by one between two passes (:meth:`CollisionModel._compute`); more: one map
TOGGLES = 12


def _pair_line(path, j: int) -> int | None:
    """The line (1-based) of the j-th pair of a pair file, or None."""
    if path is None:
        return None
    from ..validation.yamlio import read_document

    return read_document(path, RobotDefinitionError).line(f"pairs[{j}]")


class CollisionModel:
    """A robot's collision geometry, pairs and broad phase (module docstring).

    Args:
        robot: the :class:`~wbc.model.RobotModel` (its URDF's collision elements are read).
        obstacles: fixed obstacles (:class:`~wbc.collision.shapes.Obstacle`).
        obstacle_links: robot links (URDF names) checked against the obstacles; None: all.
        self_collision: whether self pairs are monitored.
        self_pairs: explicit self pairs (geometry names); None: the pair file beside the robot
            YAML if there is one, else (and with ``"default"``) every pair minus the SRDF's
            disabled and adjacent ones.
        hull_dir: the hull cache directory (None: :func:`wbc.collision.hulls.cache_dir`).
        primitives: replace the geometries that have one by the primitive of the robot's collision file
            (:mod:`wbc.collision.primitives`); an error if it has none.
    """

    def __init__(self, robot, obstacles: Sequence[Obstacle] = (), obstacle_links: list[str] | None = None,
                 self_collision: bool = True, self_pairs: list[tuple[str, str]] | str | None = None,
                 hull_dir: Path | None = None, primitives: bool = False) -> None:
        from .pairs import default_self_pairs, pair_file, read_pair_file

        self.robot = robot
        model = robot.model
        if robot.urdf_path is None:
            raise RobotDefinitionError(f"robot '{robot.name}' has no URDF: no collision geometry")
        gm = pin.buildGeomFromUrdf(model, str(robot.urdf_path), pin.GeometryType.COLLISION, None,
                                   robot.package_dirs)
        if gm.ngeoms == 0:
            raise RobotDefinitionError(f"robot '{robot.name}': its URDF '{robot.urdf_path}' has no <collision> "
                                       "geometry, so collisions cannot be monitored")
        for g in gm.geometryObjects:
            if isinstance(g.geometry, coal.BVHModelBase):
                g.geometry = convex_hull(g.geometry, g.meshPath, g.meshScale, hull_dir)
        self.n_robot = gm.ngeoms
        robot_names = [g.name for g in gm.geometryObjects]
        self.primitive_names: list[str] = []
        if primitives:
            from .primitives import use_primitives

            #: the geometries replaced by a primitive
            self.primitive_names = use_primitives(robot, gm, robot_names)
        for ob in obstacles:
            gm.addGeometryObject(pin.GeometryObject(ob.name, 0, 0, ob.placement, ob.geometry))
        self.geometry_model = gm
        self.geometry_data = pin.GeometryData(gm)
        self.names = [g.name for g in gm.geometryObjects]
        self.links = [model.frames[g.parentFrame].name for g in gm.geometryObjects]
        pairs: list[tuple[int, int]] = []
        if self_collision:
            read = None
            if self_pairs is None:
                self_pairs = read = read_pair_file(robot)
            chosen: list[tuple[str, str]] = (default_self_pairs(robot, gm, self.n_robot)
                                              if self_pairs is None or isinstance(self_pairs, str) else list(self_pairs))
            idx = {n: i for i, n in enumerate(robot_names)}
            source = pair_file(robot) if read is not None and self_pairs is read else None
            for j, (a, b) in enumerate(chosen):
                for name in (a, b):
                    if name not in idx:
                        raise RobotDefinitionError(f"no robot geometry '{name}' (self pair [{a}, {b}]); expected "
                                                   f"one of {robot_names}", key=f"pairs[{j}]", file=source,
                                                   line=_pair_line(source, j))
                pairs.append((idx[a], idx[b]))
        for k in range(len(obstacles)):
            ob = self.n_robot + k
            for i in range(self.n_robot):
                if obstacle_links is None or self.links[i] in obstacle_links:
                    pairs.append((i, ob))
        gm.removeAllCollisionPairs()
        for i0, i1 in pairs:
            gm.addCollisionPair(pin.CollisionPair(int(i0), int(i1)))
        self.geometry_data = pin.GeometryData(gm)
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        spheres = [bounding_sphere(g.geometry) for g in gm.geometryObjects]
        self.centres = np.array([c for c, _ in spheres])
        self.radii = np.array([r for _, r in spheres])
        self.joint_of = np.array([g.parentJoint for g in gm.geometryObjects], dtype=np.int64)
        self.planes = {i: (np.array(g.geometry.n), float(g.geometry.d)) for i, g in enumerate(gm.geometryObjects)
                       if isinstance(g.geometry, coal.Halfspace)}
        self._cycle: Any = None
        self._rows: Any = None
        #: J̇_d q̇ from the distance's exact second difference (:func:`.drift.curvature_drift`); False: rigid, cheaper
        self.exact_drift = True
        #: J̇_d q̇ from the closest features' local models (:mod:`.feature_drift`, ``drift: analytic``), with
        #: ``exact_drift``; ``switch_jump``: the rows' ``jump`` too (``drift: switching``)
        self.analytic_drift = self.switch_jump = False
        self.feature_drift: Any = None
        self.drift_step = 1e-2
        #: ``switch_jump``'s short step (s; four more coal passes; None: none): :func:`wbc.collision.drift.switch_jump`
        self.switch_step: float | None = 2.5e-4
        self.fd_data = model.createData()
        self.fd_geometry_data = pin.GeometryData(gm)
        for req in self.fd_geometry_data.distanceRequests:
            req.gjk_tolerance = 1e-8
        #: (njoints × nv) 1 where joint j's Jacobian may be non-zero (its supporting chain)
        self.support: np.ndarray = np.zeros((model.njoints, model.nv))
        for j in range(1, model.njoints):
            for s in model.supports[j]:
                if s > 0:
                    jm = model.joints[s]
                    self.support[j, jm.idx_v:jm.idx_v + jm.nv] = 1.0
        self._all_map = np.zeros((gm.ngeoms, gm.ngeoms), dtype=bool)
        if len(self.pairs):
            self._all_map[self.pairs[:, 0], self.pairs[:, 1]] = True
        # broad phase, precomputed per pair (module docstring, step 1)
        self._pa, self._pb = self.pairs[:, 0].copy(), self.pairs[:, 1].copy()
        self._rsum = self.radii[self._pa] + self.radii[self._pb]
        self._plane_pairs = np.flatnonzero(~np.isfinite(self._rsum))
        # the pairs' bound from their last exact distance and the joints' motion since (_near)
        self._weights_t = np.ascontiguousarray(motion_weights(model, gm, self.pairs, spheres).T)   # (nv × pairs)
        self._spans = weight_spans(self._weights_t)
        self._d0 = np.full(len(self.pairs), -np.inf)
        self._moved = np.zeros(len(self.pairs))
        self._q_last: np.ndarray | None = None
        self._held: Any = None                  # the cycle's GeometryData's _entry
        self._near_buf = np.zeros(len(self.pairs), dtype=np.int64)
        self._no_step = np.zeros(model.nv)
        self._rows_at_scratch = np.zeros((2, len(self.pairs)))
        self._on = np.zeros(len(self.pairs), dtype=np.int64)      # _compute's pairs to activate / deactivate
        self._off = np.zeros(len(self.pairs), dtype=np.int64)
        self._map = np.zeros((gm.ngeoms, gm.ngeoms), dtype=bool)
        self._check_map = np.zeros_like(self._map)        # rows_at's active pairs (its own, reused)
        #: per GeometryData (by id): it, its distance results as Python proxies (indexing ``distanceResults`` costs
        #: ~3 µs a pair a call; a proxy stays bound to its C++ result), their held table and its active pairs (_entry)
        self._proxies: dict[int, tuple[pin.GeometryData, list, ResultTable, np.ndarray]] = {}
        #: how many pairs the last :meth:`distance_rows` computed exactly (the broad phase's output)
        self.computed = 0

    # ------------------------------------------------------------ queries
    def link_geometries(self, links: list[str] | None = None) -> list[tuple[str, str, pin.SE3, np.ndarray]]:
        """The robot geometries on ``links`` (None: those paired with an obstacle), for another simulator to collide (MuJoCo,
        :func:`wbc.sim.mujoco_model.build_model`'s ``link_geoms``): (geometry name, its joint's name, placement in the
        joint's frame, hull vertices n × 3 in m). Non-mesh primitives are given by the vertices of their convex hull
        too (sampled surface: boxes' corners, spheres' and capsules' 26-point shells)."""
        if links is None:
            obstacles = set(range(self.n_robot, self.geometry_model.ngeoms))
            wanted = {int(i) for i, j in self.pairs if int(j) in obstacles}
        else:
            wanted = {i for i in range(self.n_robot) if self.links[i] in links}
        out = []
        for i in sorted(wanted):
            g = self.geometry_model.geometryObjects[i]
            out.append((g.name, self.robot.model.names[g.parentJoint], g.placement, hull_vertices(g.geometry)))
        return out

    def results(self, gd: pin.GeometryData) -> list:
        """The distance results of ``gd`` (one per pair, coal ``DistanceResult``), live: each reads the last
        :func:`pin.computeDistances` on ``gd``. Made once per GeometryData."""
        return self._entry(gd)[1]

    def _entry(self, gd: pin.GeometryData) -> tuple[pin.GeometryData, list, ResultTable, np.ndarray]:
        """``gd``'s held proxies, its :class:`~wbc.collision.result_table.ResultTable` and which of its pairs are active
        (pairs,; as :meth:`_compute` last set them, all at first: a GeometryData starts with every pair active), made
        once."""
        entry = self._proxies.get(id(gd))
        if entry is None or entry[0] is not gd:
            res = gd.distanceResults
            proxies = [res[k] for k in range(len(self.pairs))]
            active = np.array([bool(a) for a in gd.activeCollisionPairs], dtype=np.bool_)
            entry = (gd, proxies, ResultTable(proxies), active)
            self._proxies[id(gd)] = entry
        return entry

    def broad_references(self) -> tuple[np.ndarray, np.ndarray]:
        """The broad phase's per-pair state, (d0, moved) (pairs,; m): each pair's last exact distance and the bound
        on how far its geometries moved since. The rows' calls after coal update both in place for the pairs coal
        computed (:func:`wbc.collision.row_kernels.held_near_rows`, the fused analytic call)."""
        return self._d0, self._moved

    def pair_name(self, k: int) -> str:
        a, b = self.pairs[k]
        return f"{self.names[a]}/{self.names[b]}"

    def _compute(self, ks: np.ndarray | None, gd: pin.GeometryData, cmap: np.ndarray | None) -> None:
        """Activate the pairs ``ks`` (None: all) of ``gd`` and run coal on them (pinocchio's ``computeDistances``)."""
        gm = self.geometry_model
        active = self._entry(gd)[3]
        if ks is None:
            gd.setActiveCollisionPairs(gm, self._all_map)
            active[:] = True
        else:
            n_on, n_off = toggles(active, ks, self._on, self._off)
            self._switch(gd, ks, n_on, n_off, cmap)
        pin.computeDistances(gm, gd)

    def _switch(self, gd: pin.GeometryData, ks: np.ndarray, n_on: int, n_off: int, cmap: np.ndarray | None) -> None:
        """Make ``ks`` the active pairs of ``gd``, given :func:`~wbc.collision.row_kernels.toggles`' ``n_on`` pairs to
        activate (in ``self._on``) and ``n_off`` to deactivate (``self._off``)."""
        if n_on + n_off <= TOGGLES:             # the few pairs that changed, one binding call each (~0.4 µs)
            for k in self._on[:n_on].tolist():
                gd.activateCollisionPair(k)
            for k in self._off[:n_off].tolist():
                gd.deactivateCollisionPair(k)
        else:
            cmap = self._map if cmap is None else cmap
            cmap[:] = False
            cmap[self._pa[ks], self._pb[ks]] = True
            gd.setActiveCollisionPairs(self.geometry_model, cmap)

    def pair_results(self, ks: np.ndarray | None, gd: pin.GeometryData | None = None,
                     cmap: np.ndarray | None = None) -> list:
        """coal's distances (pinocchio's ``computeDistances``, in C++) of the pairs ``ks`` (indices into :attr:`pairs`;
        None: all) on the placements already updated in ``gd`` (default :attr:`geometry_data`), and their results
        (coal ``DistanceResult``, in the order of ``ks``): the one place pairs are activated and computed
        (:meth:`pair_table` reads the same pass as one array).

        Args:
            ks: pair indices (k,), or None for every pair.
            gd: the geometry data (placements in, results out).
            cmap: the (ngeoms × ngeoms) bool map of active pairs to fill (reused across calls); None: the model's own.
        """
        gd = self.geometry_data if gd is None else gd
        self._compute(ks, gd, cmap)
        res = self.results(gd)
        return res if ks is None else [res[k] for k in ks.tolist()]

    def pair_table(self, ks: np.ndarray, gd: pin.GeometryData | None = None,
                   cmap: np.ndarray | None = None) -> np.ndarray:
        """:meth:`pair_results`' pass, read as one (k × 7) array: per pair of ``ks``, [d, n, p₁] (m; coal's
        ``min_distance``, ``normal``, ``getNearestPoint1()``), from the held :class:`~wbc.collision.result_table.ResultTable`
        (one indexing), or through the proxies where the table is not confirmed (the same values).

        Args:
            ks: pair indices (k,).
            gd: the geometry data (placements in, results out).
            cmap: the active-pair map to fill (:meth:`pair_results`).
        """
        gd = self.geometry_data if gd is None else gd
        self._compute(ks, gd, cmap)
        _, res, table, _ = self._entry(gd)
        if table.rows is None and not table.failed and len(ks):
            table.confirm(ks)
        if table.rows is not None:
            return table.rows[ks]
        return proxy_rows(res, ks)

    def pair_distances(self, ks: np.ndarray, gd: pin.GeometryData | None = None,
                       cmap: np.ndarray | None = None) -> np.ndarray:
        """coal's distances (k,; m) of the pairs ``ks`` (:meth:`pair_table`'s first column)."""
        return self.pair_table(ks, gd, cmap)[:, 0]

    def all_distances(self, q: np.ndarray, data: pin.Data | None = None,
                      geometry_data: pin.GeometryData | None = None) -> np.ndarray:
        """The exact distance of every monitored pair at ``q`` (m), on its own pinocchio data (for monitoring the simulator's true
        state; the control cycle's rows, computed before, are kept).

        Args:
            q: the configuration (nq).
            data: pinocchio data to compute the placements in (None: a new one).
            geometry_data: where the distance results go (None: :attr:`geometry_data`, the
                control cycle's; a monitor passes its own, :meth:`new_geometry_data`).
        """
        model = self.robot.model
        data = model.createData() if data is None else data
        gd = self.geometry_data if geometry_data is None else geometry_data
        pin.forwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, self.geometry_model, gd)
        return np.array([r.min_distance for r in self.pair_results(None, gd)])

    smallest_distances = smallest_distances     # the monitor's query (wbc.collision.nearest)
    bounds_at = bounds_at
    _broad_gaps = broad_gaps
    step_scale = step_scale         # the velocity command's step check (wbc.collision.step.step_scale)

    def new_geometry_data(self) -> pin.GeometryData:
        """A GeometryData of its own (placements and results apart from the control cycle's), with the same distance requests
        (tolerances) as :attr:`geometry_data`."""
        gd = pin.GeometryData(self.geometry_model)
        for mine, theirs in zip(gd.distanceRequests, self.geometry_data.distanceRequests):
            mine.gjk_tolerance = theirs.gjk_tolerance
        return gd

    def witness_of(self, k: int, geometry_data: pin.GeometryData | None = None):
        """Pair k's last distance result in ``geometry_data`` (default :attr:`geometry_data`): (d in m, p1, p2 world witness
        points in m, unit normal n from the first to the second)."""
        gd = self.geometry_data if geometry_data is None else geometry_data
        res = self.results(gd)[k]
        return (float(res.min_distance), np.array(res.getNearestPoint1()), np.array(res.getNearestPoint2()),
                np.array(res.normal))

    def witness(self, influence: float, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                                 np.ndarray]:
        """Broad then exact phase on the placements already updated for ``q``: (pair indices, d, p1, p2, n) of the pairs closer
        than ``influence`` (m); arrays (k,), (k,), (k × 3) × 3."""
        ks, d, P, NN, _, _, _ = self._near(influence, q)
        m = len(ks)
        return ks, d, P[:m], P[m:], NN[m:]

    def _near(self, influence: float, q: np.ndarray) -> tuple:
        """The broad phase, coal on the pairs it keeps (:meth:`_pass`), and the rows of those within ``influence`` (m):
        ``near_rows``' (ks, d, P, NN, coef, jid, geoms), read by one compiled call (``held_near_rows``)."""
        near, table, res = self._pass(influence, q)
        if table.rows is not None:
            return held_near_rows(table.rows, near, influence, self._d0, self._moved, self.pairs, self.joint_of)
        return near_rows(proxy_rows(res, near), near, influence, self._d0, self._moved, self.pairs, self.joint_of)

    def _pass(self, influence: float, q: np.ndarray) -> tuple[np.ndarray, ResultTable, list]:
        """The broad phase and coal on the pairs it keeps: (those pairs, the cycle's result table, its proxies); one
        compiled call before coal (``broad_phase``).

        The broad phase keeps the pairs whose lower bound (m) from their last exact distance d₀ and the joints' motion
        since is below ``influence``: along the geodesic from the last state q₀ to q = q₀ ⊕ δ, |ḋ| ≤ Σⱼ wₖⱼ |δⱼ|
        (:func:`wbc.collision.motion.motion_weights`), so d(q) ≥ d₀ − Σ_cycles Σⱼ wₖⱼ |δⱼ|, accumulated from one cycle
        to the next (one ``pin.difference``). −∞ for a pair never computed. Exact: a pair it leaves out is farther than
        ``influence``, whatever the order or size of the steps between calls (an infinite weight times a zero step
        gives NaN: that pair's bound is −∞ until it is computed again)."""
        gd = self.geometry_data
        held = self._held
        if held is None or held[0] is not gd:
            held = self._held = self._entry(gd)
        _, res, table, active = held
        q_last = self._q_last
        if q_last is None:
            diff, add = self._no_step, False
            self._q_last = q.copy()
        else:
            diff, add = pin.difference(self.robot.model, q_last, q), True
            q_last[:] = q
        n, n_on, n_off = broad_phase(self._weights_t, self._spans, diff, self._moved, self._d0, influence, add,
                                     self._near_buf, active, self._on, self._off)
        near = self._near_buf[:n]
        self.computed = n
        if n_on or n_off:
            self._switch(gd, near, n_on, n_off, None)
        pin.computeDistances(self.geometry_model, gd)
        if table.rows is None and not table.failed and n:
            table.confirm(near)
        return near, table, res

    def distance_rows(self, robot, influence: float) -> DistanceRows:
        """The pairs closer than ``influence`` (m) at the robot's current cached state, with their distances, Jacobians
        and drifts (:class:`DistanceRows`). Once per cycle: a second call in the same ``robot.cycle`` returns the same.

        Vectorised over the k near pairs, from pinocchio's world-frame joint Jacobians ``data.J``
        (``computeJointJacobians``, done once per cycle by ``RobotModel.update``): a point p on joint j moves with
        v_p = J_v,j q̇ − p × (J_ω,j q̇) (spatial velocity at the world origin), so nᵀ v_p = [n; p × n]ᵀ J_j q̇, and the
        k rows are one (k × 6)(6 × nv) product masked by each joint's supporting chain. The drift: module docstring."""
        key = (robot.cycle, id(robot), influence)
        if self._cycle == key:
            return self._rows
        model, data = robot.model, robot.data
        pin.updateGeometryPlacements(model, data, self.geometry_model, self.geometry_data)
        analytic = self.exact_drift and self.analytic_drift
        near, table, res = self._pass(influence, robot.q)
        drift: np.ndarray | None = None
        if analytic and table.rows is not None and len(near):     # the rows and their drift in one compiled call
            ks, d, P, NN, coef, jid, drift = self._features().held_rows(robot, table.rows, near, influence)
        else:
            ks, d, P, NN, coef, jid, geoms = (
                held_near_rows(table.rows, near, influence, self._d0, self._moved, self.pairs, self.joint_of)
                if table.rows is not None else
                near_rows(proxy_rows(res, near), near, influence, self._d0, self._moved, self.pairs, self.joint_of))
        m = len(ks)
        P1, P2, N = P[:m], P[m:], NN[m:]
        J = self._jacobians(data, coef, jid)
        jump, local, d_dot = None, None, J @ robot.v
        if drift is not None:
            pass
        elif m and analytic:
            drift = self._features().drift(robot, ks, d, P, NN, jid, geoms)
        elif m and self.exact_drift and self.switch_jump:     # drift: switching: the pieces' curvature in ``local``
            drift, jump, local = switch_jump(self, robot, ks, d_dot)
        elif m:
            drift = curvature_drift(self, robot, ks) if self.exact_drift else rigid_drift(self, robot, ks, P1, P2, N)
        else:
            drift = np.zeros(0)
        rows = DistanceRows(ks, d, d_dot, J, drift, N, P1, P2, jump, local)
        self._cycle, self._rows = key, rows
        return rows

    def _features(self) -> Any:
        """The analytic drift's :class:`~wbc.collision.feature_drift.FeatureDrift`, made once."""
        if self.feature_drift is None:
            from .feature_drift import FeatureDrift
            self.feature_drift = FeatureDrift(self)
        return self.feature_drift

    def _jacobians(self, data: pin.Data, coef: np.ndarray, jid: np.ndarray) -> np.ndarray:
        """J_d (k × nv) from each side's coefficients [n_s; p_s × n_s] (2k × 6, first sides then second,
        :func:`wbc.collision.row_kernels.near_rows`), their joints ``jid`` (2k,) and the world-frame joint Jacobians in
        ``data.J`` (:meth:`distance_rows`' docstring): one (2k × 6)(6 × nv) product, each row masked by its joint's
        supporting chain, the two sides summed."""
        if not len(jid):
            return np.zeros((0, self.robot.model.nv))
        return masked_pair_sum(coef @ data.J, self.support, jid)

    def rows_at(self, q: np.ndarray, ks: np.ndarray, data: pin.Data,
                geometry_data: pin.GeometryData) -> tuple[np.ndarray, np.ndarray]:
        """The exact distances (k,; m) and distance Jacobians (k × nv) of the pairs ``ks`` at a configuration ``q`` other than the
        cycle's (the velocity mode's check of its command, :func:`wbc.tasks.velocity.collision_correction`), on the
        caller's own pinocchio and geometry data; the cycle's rows and broad phase are left as they are.

        Args:
            q: the configuration (nq).
            ks: pair indices (k,).
            data: pinocchio data of the robot's model (joint Jacobians are computed in it).
            geometry_data: a geometry data of this model (:meth:`new_geometry_data`).
        """
        model = self.robot.model
        pin.computeJointJacobians(model, data, q)
        pin.updateGeometryPlacements(model, data, self.geometry_model, geometry_data)
        table = self.pair_table(ks, geometry_data, self._check_map)
        scratch = self._rows_at_scratch            # near_rows' broad-phase references: not the cycle's
        _, d, _, _, coef, jid, _ = near_rows(table, ks, np.inf, scratch[0], scratch[1], self.pairs, self.joint_of)
        return d, self._jacobians(data, coef, jid)
