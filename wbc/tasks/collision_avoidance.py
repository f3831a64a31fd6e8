"""CollisionAvoidance: one inequality row per monitored pair closer than the influence distance.

Rows from :meth:`wbc.collision.model.CollisionModel.distance_rows` (d, J_d, J̇_d q̇ per pair;
the same rows serve a velocity level: J_d q̇ ≥ −ξ (d − d_s)/(d_i − d_s)).

Acceleration level: a second-order barrier on e = d − d_s. With h = ė + ω e (m/s),

    inside the safe set D = {h ≥ 0}:   ḣ ≥ −γ h,  i.e.  ë ≥ −(ω + γ) ė − γ ω e,
    outside it (h < 0):                ḣ ≥ −ω h,  i.e.  ë ≥ −2ω ė − ω² e   (the critically damped damper),

and J_d q̈ ≥ that bound − J̇_d q̇. The bound is the smaller of the two everywhere (they differ by (γ − ω) h).

Why it is safe: h ≥ 0 means ė ≥ −ω e, so e(t) ≥ e₀ e^{−ωt} never crosses zero; inside D, ḣ ≥ −γ h keeps
h(t) ≥ h₀ e^{−γt} ≥ 0 (comparison lemma), so D is invariant whatever γ > 0. A pair enters the rows at
e₀ = d_i − d_s with at most the approach speed v̄ (``max_speed``, m/s), i.e. h₀ = ė₀ + ω e₀ ≥ 0 with
ω = v̄/(d_i − d_s): every approach no faster than v̄ keeps d ≥ d_s, and the guarantee depends on ω alone.
On D's boundary (h = 0) the bound is ë ≥ −ω ė for every γ: the braking asked is at most ω v̄, as the damper's.
The second pole γ = ``pole_ratio`` · ω only sets how fast the boundary may be approached. γ = ω is the
critically damped damper d̈ ≥ −2ω ḋ − ω² (d − d_s) everywhere, which brakes deep inside D: a pair at rest
10 mm above d_s is held to d̈ ≥ −ω² e = −1.2 m/s² (Talos, ω = 11.1/s), so an upper arm sliding past the torso
(curvature drift J̇_d q̇ ≈ −3.3 m/s²) had to be pushed away at +2.1 m/s² while its shoulder ran at its velocity
limit: infeasible with the joint-limit rows, level 0 relaxed (``benchmarks/collisions.md``). With γ > ω the
bound inside D is lower by (γ − ω) h: never more demanding than the damper's. Outside D (h < 0: a pair that
entered faster than v̄, a jump of ḋ where the closest hull features switch, a model error) the row asks the
damper's recovery, not γ's (γ applied there too, as ḣ ≥ −γ h everywhere, asked (γ − ω)|h| more: with γ = 4ω
one ``talos_hands_cross`` run relaxed level 0 for 49 cycles and went 9 mm through). γ is not free either: the
damper's braking inside D is also a margin against the drift's errors, which are large on hulls (the ±10 ms
second difference jumps by ±1 m/s² cycle to cycle where the closest features switch, and ḋ by −14 mm/s): with
γ = 2ω or 4ω the hands' pair ``arm_left_7/arm_right_5`` rode D's boundary at 7 s and such errors took it to
0.6-3.3 mm (d_s = 5 mm) in 4 of 7 perturbed runs. Each of 1.5, 2, 4 removed the crossing's relaxed
cycles; with 1.5 the same pair still reached 2.8 mm in MuJoCo's unperturbed run, so ``pole_ratio`` stays 1 (the
damper, bit for bit) by default and no bundled scenario opts in (``benchmarks/collisions.md``).
A drift error δ (m/s²) held at the boundary leaves e = −δ/(γ ω), not −δ/ω².

Vertex rows (``vertex_rows`` > 0, opt-in). The distance between two hulls is the minimum over their
features, so it is only piecewise smooth: a row holds the closest feature alone, and a flat face
held at one witness point can rock about it until another vertex becomes the closest, arriving
with a lower ḋ (measured on ``tiago_table_reach`` in MuJoCo, the hand pushed into the table:
39 switches a second, ḋ dropping by up to 14 mm/s at each, −0.12 m/s² on average, which the
damper can only balance by ω² (d_s − d): 1.05 mm below d_s). With ``vertex_rows`` = m, each
near pair also gets rows for up to m vertices of each robot hull nearest the pair's separating
plane (the plane through the other witness point, normal n; a vertex v of the first geometry
has the gap g_v = nᵀ(p₂ − v) ≥ d, equal at the witness point), each ≥ :data:`VERTEX_SPACING`
from the witness point and the others, with the same damper on g_v: ġ_v = ḋ + (n × (v − p₁))ᵀ
J_ω q̇ (n held fixed; J_ω the world angular Jacobian of the vertex's joint) and the drift of
the pair plus the rigid difference (n × r)ᵀ α₀ − nᵀ(ω × (ω × r)), r = v − p₁. Every such
vertex then obeys the damper's bound by itself, so the minimum over them does too.

Feature switches (``drift: switching``, opt-in). Between hulls d is the minimum over feature pairs: where another
pair becomes the closest, ḋ drops by Δ < 0 (a concave kink). A faceted round surface sliding past another is a
staircase of them (Talos's upper arm past its torso at 0.5 m/s: one every 4-5 ms, ḋ dropping by 20-250 mm/s at
each, the pieces between them curving at +1.5 m/s²), and the exact drift, a second difference over ±10 ms, reads
them as J̇_d q̇ = −4 to −8 m/s², a switch already passed included: the damper then asked +2 to +4 m/s² of J_d q̈
from a pair 10 mm above d_s while the joints that move it away were at their velocity bound (level 0 relaxed).
A switch is a jump of ė, not an acceleration: it needs no braking if it leaves the pair in D (h + Δ ≥ 0), which
the damper then keeps on the new features. With ``switching`` the same three coal passes also give the one-sided
differences a±(ε) = ±2 [d(q ⊕ ±εv) − d ∓ ḋ ε]/ε² (ε = 10 ms; their mean is the exact drift), and four more passes
at ±s, ±2s (s = 0.25 ms) the same at s and the second differences centred at ±s: d is never above the distance of
the features closest at a difference's base (or middle) point, so a switch inside its interval only lowers it, and
a = the largest of the six is the pieces' curvature, never above it; Δ̂ = −ε/2 · max(0, a − a₊(ε)) the jumps of the
switches ahead (Σ Δ (ε − τ)/ε, tending to Δ as one nears; 0 for one passed, :func:`wbc.collision.drift.switch_jump`).
The short ones matter where switches fall on both sides of the ±10 ms window (every 0.5-5 ms on Talos's upper arm:
a±(ε) both −4 to −7 m/s² while the pieces curve at +1 to +2.6, and level 0 relaxed in 0-8 cycles of each perturbed
crossing).
Where ḋ + Δ̂ + ω e ≥ 0 the row is the damper at the velocity after the switch with the pieces' drift, ë ≥
−2ω (ė + Δ̂) − ω² e − a (never below the damper of the current features: Δ̂ ≤ 0); elsewhere (a switch that would
take the pair out of D, e.g. at d_s) the exact drift's row, which brakes the switch ahead as before.

Rows are fixed in number (``max_rows``, so that the stack's buffers keep their size): the
nearest pairs first; the unused rows are 0 ≤ 0 · x ≤ 1, always satisfied. Units: m, m/s, m/s².
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np

from wbc.validation.schema import boolean, number, sequence, text

from ..errors import TaskDefinitionError
from ..options import Options
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task

#: the bound of an unused row's 0 · x (any positive number: the row is always satisfied)
_FREE = 1.0
#: the least distance (m) between a vertex row's vertex and the pair's witness point or another vertex row's
VERTEX_SPACING = 0.01


@dataclass(frozen=True)
class CollisionOptions(Options):
    """What a :class:`CollisionAvoidance` task monitors (each checked by the task)."""

    max_rows: int = 16
    """rows kept each cycle (the nearest pairs)"""
    self_collision: bool = True
    """the robot's self pairs are monitored"""
    obstacles: Sequence[Any] = ()
    """fixed obstacles (:class:`~wbc.collision.shapes.Obstacle` or their YAML mappings)"""
    links: list[str] | None = None
    """robot links checked against the obstacles (None: all)"""
    environment: bool = False
    """the scenario's ``environment:`` shapes are obstacles too"""
    geometry: str = "hulls"
    """the robot's shapes: ``hulls`` (each mesh's convex hull) or ``primitives`` (the capsules, spheres and boxes of
    the robot's collision file where it has one, :mod:`wbc.collision.primitives`)"""
    vertex_rows: int = 0
    """per near pair, rows for up to this many hull vertices nearest its separating plane (module docstring)"""
    pole_ratio: float = 1.0
    """γ/ω ≥ 1: the barrier's second pole −γ (module docstring; 1: the critically damped damper everywhere)"""
    drift: str = "exact"
    """the rows' J̇_d q̇: ``exact`` (the distance's second difference, three more coal passes), ``analytic`` (the
    closest features' local model, no coal pass: :mod:`wbc.collision.feature_drift`) or ``switching`` (the exact
    passes, a feature switch ahead taken as a jump of ḋ where it leaves the pair in the safe set: module docstring)"""


@nb.njit(cache=True)
def damper_rows(C, lo, hi, J, d, d_dot, drift, order, omega, gamma, safety, free):
    """Row r of ``C`` (m × nx), ``lo``, ``hi`` from pair ``order[r]``: J_d in its first nv columns, the barrier's
    bound (m/s², module docstring) lo = −(ω + γ) ḋ − γ ω (d − d_s) − J̇_d q̇ inside the safe set (h = ḋ + ω (d − d_s)
    ≥ 0), the critically damped −2ω ḋ − ω² (d − d_s) − J̇_d q̇ outside it (the smaller of the two, everywhere), hi = ∞;
    the rows past ``len(order)`` unused (0 ≤ 0 · x ≤ ``free``). γ = ω gives the critically damped row everywhere,
    bit for bit. In one call (the numpy form was ~12 calls)."""
    C[:, :] = 0.0
    lo[:] = 0.0
    hi[:] = free
    a = -2.0 * omega
    b = omega * omega
    a_in = -(omega + gamma)
    b_in = gamma * omega
    nv = J.shape[1]
    for r in range(len(order)):
        i = order[r]
        for c in range(nv):
            C[r, c] = J[i, c]
        e = d[i] - safety
        if gamma > omega and d_dot[i] + omega * e > 0.0:
            lo[r] = a_in * d_dot[i] - b_in * e - drift[i]
        else:
            lo[r] = a * d_dot[i] - b * e - drift[i]
        hi[r] = np.inf


def barrier_bound(omega: float, gamma: float, e: float, e_dot: float) -> float:
    """The bound on ë (m/s²) of one row before its drift (module docstring): −(ω + γ) ė − γ ω e inside the safe set
    (ė + ω e > 0), −2ω ė − ω² e outside it; e = d − d_s (m), ė (m/s), ω, γ (1/s)."""
    if gamma > omega and e_dot + omega * e > 0.0:
        return -(omega + gamma) * e_dot - gamma * omega * e
    return -2.0 * omega * e_dot - omega * omega * e


class CollisionAvoidance(Task):
    """Keep every monitored pair at least ``safety`` (d_s, m) apart (module docstring).

    Args:
        influence: d_i (m): pairs closer than this get a row.
        safety: d_s (m) < d_i: the distance never to go below.
        max_speed: v̄ (m/s), the fastest approach the damper stops in time; ω = v̄/(d_i − d_s).
        name: the task's name in the stack (unique).
        weight: its weight within its level (unitless, > 0).
        options: what is monitored, below, in one :class:`CollisionOptions` (None: its defaults).
        **settings: its fields one by one, over ``options`` (another name is a TypeError):

        max_rows: rows kept each cycle (the nearest pairs).
        self_collision: whether the robot's self pairs are monitored.
        obstacles: fixed obstacles (:class:`~wbc.collision.shapes.Obstacle` or their YAML mappings,
            :func:`wbc.collision.shapes.obstacle`).
        links: robot links checked against the obstacles (None: all).
        environment: whether the scenario's ``environment:`` shapes (ground, planes, boxes, spheres,
            cylinders) are obstacles too (against ``links``; the scenario loader hands them over,
            :meth:`use_environment`).
        geometry: ``hulls`` (default) or ``primitives``: the robot's collision file's primitives
            (capsules, spheres, boxes; each contains the hull it replaces) where it has one, for speed.
        vertex_rows: per near pair and robot hull, rows for up to this many vertices nearest the
            pair's separating plane (module docstring; 0: none), within the ``max_rows`` rows.
        drift: ``exact`` (default: the distance's second difference over ±10 ms, three more coal
            passes), ``analytic`` (the closest features' local model, no coal pass,
            :mod:`wbc.collision.feature_drift`) or ``switching`` (the exact passes; a feature switch ahead
            that leaves the pair in the safe set is a jump of ḋ: module docstring).
    """

    kind = "collision_avoidance"

    options_record = CollisionOptions

    def __init__(self, influence: float = 0.05, safety: float = 0.01, max_speed: float = 0.5,
                 name: str = "collision_avoidance", weight: float = 1.0, options: CollisionOptions | None = None,
                 **settings) -> None:
        super().__init__(name, weight)
        owner = f"task '{self.name}'"
        o = CollisionOptions.of(options, settings, owner)
        max_rows, self_collision, obstacles, links, environment = (o.max_rows, o.self_collision, o.obstacles,
                                                                   o.links, o.environment)
        self.influence = number(influence, "influence", gt=0, le=1, unit="m", error=TaskDefinitionError, owner=owner)
        self.safety = number(safety, "safety", ge=0, le=1, unit="m", error=TaskDefinitionError, owner=owner)
        if self.safety >= self.influence:
            raise TaskDefinitionError(f"{owner}: safety (d_s = {self.safety:g} m) must be below influence "
                                      f"(d_i = {self.influence:g} m)", key="safety")
        self.max_speed = number(max_speed, "max_speed", gt=0, le=100, unit="m/s", error=TaskDefinitionError,
                                owner=owner)
        self.max_rows = int(number(max_rows, "max_rows", ge=1, le=1000, error=TaskDefinitionError, owner=owner))
        err: dict[str, Any] = {"error": TaskDefinitionError, "owner": owner}
        self.self_collision = boolean(self_collision, "self_collision", **err)
        from wbc.collision.shapes import Obstacle, obstacle

        obstacles = sequence(obstacles, "obstacles", what="a list of obstacle mappings", **err)
        self.obstacles = [o if isinstance(o, Obstacle) else obstacle(o, f"obstacles[{i}]", f"obstacle_{i}")
                          for i, o in enumerate(obstacles)]
        self.links = None if links is None else [
            text(x, f"links[{i}]", what="a link name", **err)
            for i, x in enumerate(sequence(links, "links", min_len=1, what="a list of link names", **err))]
        self.environment = boolean(environment, "environment", **err)
        self.geometry = text(o.geometry, "geometry", choices=["hulls", "primitives"], **err)
        self.vertex_rows = int(number(o.vertex_rows, "vertex_rows", ge=0, le=100, **err))
        self.drift = text(o.drift, "drift", choices=["exact", "analytic", "switching"], **err)
        self.pole_ratio = number(o.pole_ratio, "pole_ratio", ge=1, le=1000, **err)
        self._vertices: dict[int, np.ndarray | None] = {}   # robot hull -> its vertices in its joint's frame
        #: the last cycle's vertex rows, in row order after the pairs' rows: (pair, side 0/1 (the vertex on the
        #: pair's first or second geometry), geometry, vertex index, normal n, the other witness point (m, world))
        self.vertex_last: list[tuple[int, int, int, int, np.ndarray, np.ndarray]] = []
        self.environment_obstacles: list = []
        self.omega = self.max_speed / (self.influence - self.safety)
        #: γ (1/s), the barrier's second pole (module docstring)
        self.gamma = self.pole_ratio * self.omega
        self.model: Any = None          # the CollisionModel, built at bind
        self._buf: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._out: Rows | None = None     # the Rows of ``_buf``, returned by every ``rows`` call
        #: the last cycle's rows (wbc.collision.model.DistanceRows) and which are active
        self.last: tuple[Any, np.ndarray] | None = None
        #: (pinocchio Data, GeometryData) of the velocity mode's check of its command
        #: (:func:`wbc.tasks.velocity.collision_correction`), made on first use
        self.correction_data: tuple[Any, Any] | None = None

    def bind(self, robot) -> None:
        if self.model is None or self.model.robot is not robot:
            from wbc.collision.model import CollisionModel

            self.model = CollisionModel(robot, obstacles=self.obstacles + self.environment_obstacles,
                                        obstacle_links=self.links, self_collision=self.self_collision,
                                        primitives=self.geometry == "primitives")
            self.model.analytic_drift = self.drift == "analytic"
            self.model.switch_jump = self.drift == "switching"
            if self.links is not None:
                unknown = sorted(set(self.links) - {robot.model.frames[i].name for i in range(robot.model.nframes)})
                if unknown:
                    raise TaskDefinitionError(f"no link {unknown} in robot '{robot.name}'", key="links")
                bare = sorted(set(self.links) - set(self.model.links))
                if bare:
                    raise TaskDefinitionError(f"link(s) {bare} of robot '{robot.name}' have no collision geometry; links "
                                      f"with some: {sorted(set(self.model.links))}", key="links")

    def use_environment(self, shapes, robot) -> None:
        """The scenario's environment shapes (:mod:`wbc.sim.environment`) become obstacles of this
        task (if it was built with ``environment: true``), against its ``links``; rebinds to ``robot``."""
        if not self.environment:
            return
        from wbc.collision.shapes import from_environment

        self.environment_obstacles = from_environment(shapes)
        self.model = None
        self.bind(robot)

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        self.bind(robot)
        if self._buf is None or self._buf[0].shape[1] != layout.nx:
            n = self.max_rows
            self._buf = (np.zeros((n, layout.nx)), np.zeros(n), np.full(n, _FREE))
            self._out = Rows(C=self._buf[0], lo=self._buf[1], hi=self._buf[2])
        C, lo, hi = self._buf
        held = self._out
        assert held is not None
        r = self.model.distance_rows(robot, self.influence)
        order = r.d.argsort()[: self.max_rows]          # np.argsort's sort, without its dispatch
        k = len(order)
        d_dot, drift = r.d_dot, r.drift
        if r.jump is not None:      # drift: switching (module docstring): a switch that leaves the pair in D
            inside = r.d_dot + r.jump + self.omega * (r.d - self.safety) >= 0.0
            d_dot, drift = np.where(inside, r.d_dot + r.jump, r.d_dot), np.where(inside, r.local, r.drift)
        damper_rows(C, lo, hi, r.J, r.d, d_dot, drift, order, self.omega, self.gamma, self.safety, _FREE)
        self.vertex_last = []
        if k and self.vertex_rows and k < self.max_rows:
            n = self._vertex_rows(robot, r, order, C[k:, : robot.nv], lo[k:])
            hi[k:k + n] = np.inf
        self.last = (r, order)
        return held          # the buffer's arrays, refilled above: one Rows for every cycle

    def _hull_vertices(self, g: int) -> np.ndarray | None:
        """Robot geometry ``g``'s hull vertices in its joint's frame (None: not a hull)."""
        if g not in self._vertices:
            import coal

            go = self.model.geometry_model.geometryObjects[g]
            V = None
            if g < self.model.n_robot and isinstance(go.geometry, coal.ConvexBase):
                P = np.asarray(go.geometry.points(), dtype=float).reshape(-1, 3)
                V = P @ go.placement.rotation.T + go.placement.translation
            self._vertices[g] = V
        return self._vertices[g]

    def _vertex_rows(self, robot, r, order: np.ndarray, C: np.ndarray, lo: np.ndarray) -> int:
        """Fill ``C``, ``lo`` with the vertex rows of the pairs ``order`` (module docstring), nearest
        gap first, as many as fit; returns how many."""
        import pinocchio as pin

        from wbc.collision.drift import point_drift

        m, data = self.model, robot.data
        w = self.omega
        cand = []      # (gap, row, bound)
        for i in order.tolist():
            n, p1, p2 = r.normal[i], r.p1[i], r.p2[i]
            for side in (0, 1):
                g = int(m.pairs[r.pairs[i], side])
                V = self._hull_vertices(g)
                if V is None:
                    continue
                jid = int(m.joint_of[g])
                M = data.oMi[jid]
                X = V @ M.rotation.T + M.translation
                gaps = (p2 - X) @ n if side == 0 else (X - p1) @ n
                near = np.flatnonzero(gaps < self.influence)
                if not len(near):
                    continue
                wit, other = (p1, p2) if side == 0 else (p2, p1)
                sign = -1.0 if side == 0 else 1.0        # g = sign nᵀ(x − plane point)
                kept: list[np.ndarray] = [wit]
                Jw = pin.getJointJacobian(robot.model, data, jid, pin.LOCAL_WORLD_ALIGNED)[3:]
                jo = int(m.joint_of[int(m.pairs[r.pairs[i], 1 - side])])
                for j in near[np.argsort(gaps[near])].tolist():
                    if len(kept) > self.vertex_rows:
                        break
                    x = X[j]
                    if min(float(np.linalg.norm(x - y)) for y in kept) < VERTEX_SPACING:
                        continue
                    kept.append(x)
                    # x on the witness's body: v_x = v_wit + ω × r, r = x − wit, so ġ = ḋ + sign (r × n)ᵀ J_ω q̇
                    row = r.J[i] + sign * np.cross(x - wit, n) @ Jw
                    g_dot = float(row @ robot.v)
                    gap = float(gaps[j])
                    cand.append((gap, row, barrier_bound(w, self.gamma, gap - self.safety, g_dot),
                                 (int(r.pairs[i]), side, g, j, n.copy(), other.copy()), (jid, jo, x, sign * n)))
        cand.sort(key=lambda c: c[0])
        cand = cand[: len(lo)]
        if cand:
            # drift: sign nᵀ(a_x − a_other) at q̈ = 0, both points fixed on their bodies, n frozen
            jids = np.array([j for c in cand for j in c[4][:2]])
            P = np.array([p for c in cand for p in (c[4][2], c[3][5])])
            N = np.array([d for c in cand for d in (c[4][3], -c[4][3])])
            drift = point_drift(m, robot, jids, P, N).reshape(-1, 2).sum(axis=1)
        for j, (_, row, bound, _, _) in enumerate(cand):
            C[j] = row
            lo[j] = bound - drift[j]
        self.vertex_last = [c[3] for c in cand]
        return len(cand)

    def binding_rows(self, x: np.ndarray, tol: float = 1e-7) -> np.ndarray:
        """Which of the last cycle's rows (nearest pair first) hold at their bound for the
        solution ``x`` (the damper braking: J_d q̈ = d̈_min − J̇_d q̇ within ``tol`` m/s²); bool (k,)."""
        if self.last is None or self._buf is None:
            return np.zeros(0, dtype=bool)
        k = len(self.last[1])
        C, lo, _ = self._buf
        return C[:k] @ x <= lo[:k] + tol

    def diagnostics(self, x: np.ndarray | None = None) -> dict:
        """The last cycle's rows: ``rows_active`` (pairs within the influence distance, each a
        row), ``closest`` (the five nearest: pair name, d in m) and ``rows`` (every row: pair
        name, d in m, ḋ in m/s, and, given the solution ``x``, whether it holds at its bound)."""
        if self.last is None:
            return {"rows_active": 0, "closest": [], "rows": []}
        r, order = self.last
        bind = self.binding_rows(x) if x is not None else None
        rows = [{"pair": self.model.pair_name(int(r.pairs[i])), "d": float(r.d[i]), "d_dot": float(r.d_dot[i]),
                 **({"binding": bool(bind[j])} if bind is not None else {})} for j, i in enumerate(order)]
        return {"rows_active": len(order),
                "closest": [(row["pair"], row["d"]) for row in rows[:5]],
                "rows": rows}

    def params(self) -> dict:
        p = super().params()
        p.update(influence=self.influence, safety=self.safety, max_speed=self.max_speed, max_rows=self.max_rows,
                 self_collision=self.self_collision, environment=self.environment)
        if self.geometry != "hulls":
            p["geometry"] = self.geometry
        if self.vertex_rows:
            p["vertex_rows"] = self.vertex_rows
        if self.drift != "exact":
            p["drift"] = self.drift
        if self.pole_ratio != CollisionOptions.pole_ratio:
            p["pole_ratio"] = self.pole_ratio
        if p["name"] == "collision_avoidance":
            del p["name"]
        return p
