"""JointLimits: position and velocity limits as viable joint-acceleration bounds."""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.validation.schema import boolean, number

from ..errors import TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, Watched

#: what a joint outside its viable set is asked (:class:`JointLimits`' ``recovery``)
RECOVERIES = ("one_period", "stop")


class JointLimits(Task):
    """Box l ≤ q̈_i ≤ u for every joint with limits, the tightest of:

    - velocity, reached within one control period ``dt`` (s):
      (v_min − v)/dt ≤ q̈ ≤ (v_max − v)/dt;
    - position, over the horizon ``horizon`` (s) with constant acceleration:
      q + v T + ½ q̈ T² ∈ [q_min + margin, q_max − margin];
    - viability: after the step the joint can still stop before its limit with
      the deceleration ``max_acceleration`` ā (rad/s² or m/s²):
      v + q̈ dt ≤ √(2 ā d), d = q_max − margin − q − v dt (and symmetrically);
      a joint already faster than that (outside the viable set: a push, a simulator's
      kick) is asked to get back under that curve within one period (up to −v/dt), or with
      ``recovery: stop`` only the constant deceleration that stops it within d,
      q̈ ≤ −v²/(2d).

    Where the bounds cross (a state already outside), both collapse to their
    midpoint, the least-violating choice. Units: rad or m per joint.

    Args:
        dt: the control period the velocity bound is reached in (s, in [1e-6, 1]); default 1 ms.
        horizon: the position bound's look-ahead T (s, in [1e-6, 100]); default 0.1 s.
        max_acceleration: the viability bound's deceleration ā (rad/s² or m/s², in (0, 1e6]);
            default 30.
        margin: distance kept from each position limit (rad or m, in [0, 1]); default 0.
        recovery: a joint outside its viable set: ``"one_period"`` (default) back under the
            ā curve within one period; ``"stop"`` the constant deceleration v²/(2d) that stops
            it within d (far smaller after a simulator's kick near a stop: the go2's calf
            0.02 rad from its limit, 540 → 110 rad/s²; but under a push the joints arrive at
            their limits with no room left: talos_push falls earlier with it).
        rate_limit: (velocity mode only) also bound the commanded q̇'s change over one control
            period by ``max_acceleration``: |q̇ − v| ≤ ā dt, v the measured velocity, so that a
            position servo can follow the command (a step in q̇ is a step in the servo's error);
            default False (inverse kinematics takes full steps). The torque mode ignores it
            (its bounds are on q̈ already).
        name: the task's name, unique in a stack; default ``"joint_limits"``.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
    """

    kind = "joint_limits"
    horizon: float = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)
    margin: float = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)
    rate_limit: bool = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)

    def __init__(self, dt: float = 1e-3, horizon: float = 0.1, max_acceleration: float = 30.0,
                 margin: float = 0.0, rate_limit: bool = False, name: str = "joint_limits",
                 weight: float = 1.0, recovery: str = "one_period") -> None:
        super().__init__(name, weight)
        owner = f"task '{self.name}'"
        # bounded so that the bounds' 1/dt and 2/horizon² stay finite
        self.dt = number(dt, "dt", ge=1e-6, le=1, unit="s", error=TaskDefinitionError, owner=owner)
        self.horizon = number(horizon, "horizon", ge=1e-6, le=100, unit="s", error=TaskDefinitionError, owner=owner)
        self.max_acceleration = number(max_acceleration, "max_acceleration", gt=0, le=1e6, unit="rad/s² or m/s²",
                                       error=TaskDefinitionError, owner=owner)
        self.margin = number(margin, "margin", ge=0, le=1, unit="rad or m", error=TaskDefinitionError, owner=owner)
        self.rate_limit = boolean(rate_limit, "rate_limit", error=TaskDefinitionError, owner=owner)
        if recovery not in RECOVERIES:
            raise TaskDefinitionError(f"must be one of {list(RECOVERIES)}, got {recovery!r}", key="recovery", owner=owner)
        self.recovery = recovery
        self._map = None

    def _indices(self, robot):
        if self._map is None:
            m = robot.model
            qi, vi = [], []
            for jid in range(1, m.njoints):
                j = m.joints[jid]
                if j.nq == 1 and j.nv == 1:
                    qi.append(j.idx_q)
                    vi.append(j.idx_v)
            qi, vi = np.array(qi, dtype=np.int64), np.array(vi, dtype=np.int64)
            # velocity-only coordinates (e.g. a planar base with finite v_max)
            extra = np.array([i for i in range(robot.nv) if i not in set(vi) and np.isfinite(robot.v_max[i])],
                             dtype=np.int64)
            # the robot's limits, read once (they do not change), and the bounds' indices:
            # one array for every cycle
            self._lim = (robot.q_max[qi].copy(), robot.q_min[qi].copy(), robot.v_max[vi].copy(),
                         robot.v_max[extra].copy())
            self._map = (qi, vi, extra, np.concatenate([vi, extra]))
        return self._map

    def coordinates(self, robot) -> tuple[tuple, tuple]:
        """((q indices, v indices of the joints with limits, velocity-only coordinates with a
        finite v_max, every bounded v index), (q_max, q_min, v_max of those joints, v_max of
        the velocity-only ones)): what the bounds are built from (m, rad, m/s, rad/s)."""
        return self._indices(robot), self._lim

    def bounds(self, robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(v indices, lower, upper) acceleration bounds in rad/s² or m/s²: the joints', then
        the velocity-only coordinates' (v_min − v)/dt ≤ q̈ ≤ (v_max − v)/dt."""
        qi, vi, extra, idx = self._indices(robot)
        qmax, qmin, vmax, vmax_extra = self._lim
        lo, hi = acceleration_bounds(robot.q, robot.v, qi, vi, qmax, qmin, vmax, self.margin, self.dt,
                                     self.horizon, self.max_acceleration, extra, vmax_extra, self.recovery == "stop")
        return idx, lo, hi

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        return Rows(box=self.bounds(robot))

    def params(self) -> dict:
        p = super().params()
        p.update(dt=self.dt, horizon=self.horizon, max_acceleration=self.max_acceleration, margin=self.margin)
        if self.rate_limit:
            p["rate_limit"] = True
        if self.recovery != "one_period":
            p["recovery"] = self.recovery
        if p["name"] == "joint_limits":
            del p["name"]
        return p


@nb.njit(cache=True)
def acceleration_bounds(q, v, qi, vi, qmax, qmin, vmax, margin, dt, horizon, amax, extra, vmax_extra,
                        stop=False):
    """(lower, upper) bounds on q̈[vi] of :class:`JointLimits`, joint by joint, compiled,
    then on q̈[extra], velocity-only coordinates: (∓v_max − v)/dt.

    The upper bound is the tightest of (v_max − v)/dt, 2(q_max − margin − q − v T)/T² and
    (√(2 ā d) − v)/dt with d = max(q_max − margin − q − v dt, 0); the lower bound is the
    upper bound of the mirrored joint (q, v, q_max) → (−q, −v, −q_min), negated. Crossed
    bounds collapse to their midpoint."""
    n = qi.shape[0]
    lo = np.empty(n + extra.shape[0])
    hi = np.empty(n + extra.shape[0])
    c = 2.0 / (horizon * horizon)
    for k in range(n):
        bound = np.empty(2)
        for side in range(2):
            sgn = 1.0 if side == 0 else -1.0
            lim = (qmax[k] if side == 0 else -qmin[k]) - margin
            x = sgn * q[qi[k]]
            xd = sgn * v[vi[k]]
            h = min((vmax[k] - xd) / dt, (lim - x - xd * horizon) * c)
            d = max(lim - x - xd * dt, 0.0)
            viable = (np.sqrt(2.0 * amax * d) - xd) / dt
            if stop and viable < 0.0 and xd > 0.0 and d > 0.0:
                # outside the viable set (faster than ā can stop in d): the constant
                # deceleration that stops it within d, v²/(2d), suffices; getting back under
                # the ā curve within one period asked up to v/dt (a simulator's kick of a calf
                # 0.02 rad from its stop: 540 rad/s² where v²/(2d) is 95)
                viable = max(viable, -xd * xd / (2.0 * d))
            bound[side] = min(h, viable)
        up, low = bound[0], -bound[1]
        if low > up:
            up = low = 0.5 * (low + up)
        lo[k] = low
        hi[k] = up
    for k in range(extra.shape[0]):
        ve = v[extra[k]]
        lo[n + k] = (-vmax_extra[k] - ve) / dt
        hi[n + k] = (vmax_extra[k] - ve) / dt
    return lo, hi
