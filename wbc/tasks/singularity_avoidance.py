"""SingularityAvoidance: raise a frame's (or the CoM's) manipulability when it falls below a threshold.

The chapter's first secondary task ("singularity avoidance ... the most frequently considered
performance objective"), as one row in the null space of the tasks above it.

Manipulability (Yoshikawa) of a frame over the robot's joints (not the root):

    w(q) = √det(J_a J_aᵀ) = Π σ_i(J_a),

J_a the frame's Jacobian in its own (LOCAL) frame, the rows of ``mask``, the actuated
joints' columns (a floating root's columns are left out: the LOCAL Jacobian of the joints
does not depend on the root's pose, and the root alone never loses rank). Units: m per rad
for each position row, unitless for each orientation row, so w is in m^p (p the position
rows: m³ for ``mask: position``). w is 0 exactly at a singularity of the chain (a straight
knee, an outstretched arm, aligned wrist axes).

Gradient, analytic (no finite differences): with J_a = U Σ Vᵀ,

    ∂w/∂q_i = Σ_k (Π_{l≠k} σ_l) u_kᵀ (∂J_a/∂q_i) v_k,

and ∂J_a/∂q_i is pinocchio's Jacobian time variation at q̇ = e_i
(``computeJointJacobiansTimeVariation``; only the joints that move the frame, others give 0).
The product form stays finite at w = 0, where w⁻¹-based forms of ∇w do not.

The CoM (``frame: com``): J_a the CoM's Jacobian (``jacobianCenterOfMass``, world frame: w is
the same in any frame, a rotation of J's rows leaving its σ) over the actuated joints, position
rows only (m per rad, w in m³), the joint-limit penalty over every actuated joint with limits.
Its ∂J_a/∂q_i v_k is column i of ∂(J_com v_k)/∂q, pinocchio's CoM velocity derivative at
q̇ = v_k (``getCenterOfMassVelocityDerivatives``), one call per singular direction k.

Joint limits (``limit_penalty`` k ≥ 0, unitless): at a singularity w is often symmetric (a
straight knee bends either way) and the gradient's sign is left to rounding, or points into
a joint limit (a knee's hyperextension stop). The task therefore drives the penalised
manipulability (Tsai's form, as used for grasp planning by Vahrenkamp et al.)

    w_p = (w + w_min) · P − w_min,   P = Π_i (1 − exp(−k s_i)),
    s_i = (q_i − q_min,i)(q_max,i − q_i)/(q_max,i − q_min,i)²,

over the frame's joints with finite limits (s_i clipped at 0 outside them): w_p = w in the
middle of the ranges (P = 1), −w_min at a limit, its gradient P ∇w + (w + w_min) ∇P pointing
away from the nearer limit even where ∇w vanishes (a chain exactly at its singularity: a
straight-legged G1 bends its knees forwards, not into their hyperextension stops);
∂/∂q_i of each factor: k e^{−k s_i} (q_max,i + q_min,i − 2q_i)/(q_max,i − q_min,i)².
k = 0 is Yoshikawa's w alone. ``threshold`` applies to w_p.

Row (active while w < ``threshold`` w_min; otherwise the row is 0 = 0, no constraint):

    ∇wᵀ q̈ = K_p (w_min − w) − K_d ẇ − q̇ᵀ ∇²w q̇,     ẇ = ∇wᵀ q̇,

the PD law (5.16) on the scalar e = w_min − w, with the curvature term q̇ᵀ∇²w q̇ = d(∇w)/dt · q̇
from the analytic gradient at q ⊕ ±h q̇ (a central difference in time, h = 1e-6 s: its error
~h²|w'''| is far below the row's other terms). Below the threshold the task pushes w up
along its gradient, so a level below it (a posture) cannot straighten the knee or stretch
the arm, and one above it (a hand target) still can: priority decides.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.validation.schema import number, suggest, text

from ..errors import TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import MotionTask, eq_rows

_MASKS = {
    "position": (0, 1, 2),
    "orientation": (3, 4, 5),
    "pose": (0, 1, 2, 3, 4, 5),
}
#: time step (s) of the curvature term's central difference along q̇ (module doc)
CURVATURE_STEP = 1e-6


class SingularityAvoidance(MotionTask):
    """Keep a frame's manipulability w = √det(J_a J_aᵀ) above ``threshold`` (module doc).

    Args:
        frame: a frame alias of the robot YAML or a URDF frame name, or ``com``: the centre of
            mass (module doc; then ``mask`` must be ``"position"``).
        threshold: w_min (m^p, p the position rows of ``mask``; > 0): the task acts below it.
        mask: ``"position"`` (default), ``"orientation"`` or ``"pose"``: the rows of the
            frame's LOCAL Jacobian whose manipulability is kept.
        kp: proportional gain K_p (1/s², ≥ 0); default 100.
        kd: derivative gain K_d (1/s, ≥ 0); None (default): critical damping 2√kp.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; default ``"<frame>_manipulability"``.
        limit_penalty: k of the joint-limit penalty (unitless, ≥ 0; module doc); default 100,
            0: the plain manipulability.
    """

    kind = "singularity_avoidance"

    def __init__(self, frame: str, threshold: float, mask: str = "position", kp: float = 100.0, kd=None,
                 weight: float = 1.0, name: str | None = None, limit_penalty: float = 100.0) -> None:
        frame = text(frame, "frame", what="a frame name", error=TaskDefinitionError,
                     owner=f"task '{name or 'singularity_avoidance'}'")
        super().__init__(name or f"{frame}_manipulability", kp, kd, weight, dim=1)
        owner = f"task '{self.name}'"
        if not isinstance(self.kp, float) and np.ndim(self.kp):
            raise TaskDefinitionError("must be a number >= 0 (1/s²), got a list", key="kp", owner=owner)
        self.frame = frame
        self.threshold = number(threshold, "threshold", gt=0, unit="m^p, p the position rows of the mask",
                                error=TaskDefinitionError, owner=owner)
        if not isinstance(mask, str) or mask not in _MASKS:
            raise TaskDefinitionError(f"must be one of {list(_MASKS)}, got {mask!r}"
                                      f"{suggest(mask, _MASKS) if isinstance(mask, str) else ''}",
                                      key="mask", owner=owner)
        self.mask = mask
        #: the CoM's manipulability instead of a frame's
        self.com = frame == "com"
        if self.com and mask != "position":
            raise TaskDefinitionError(f"must be 'position' for the CoM (frame: com), got {mask!r}", key="mask",
                                      owner=owner)
        self.limit_penalty = number(limit_penalty, "limit_penalty", ge=0, le=1e6, error=TaskDefinitionError,
                                    owner=owner)
        self._sel = np.array(_MASKS[mask])
        self._lim: tuple | None = None
        self._fid: int | None = None
        self._data = None
        self._cols: np.ndarray = np.zeros(0, dtype=int)
        #: (w, ∇w) at the last state computed, keyed by the state
        self._last: tuple | None = None

    def bind(self, robot) -> None:
        m = robot.model
        self._data = m.createData()
        cols: list[int] = []
        if self.com:                    # every joint moves the CoM; the root's coordinates left out
            self._fid = -1
            cols = list(range(robot.n_root, robot.nv))
        else:
            self._fid = robot.frame_id(self.frame)
            # the joints that move the frame, without the root's coordinates
            jid = m.frames[self._fid].parentJoint
            while jid > 0:
                j = m.joints[jid]
                if j.idx_v >= robot.n_root:
                    cols.extend(range(j.idx_v, j.idx_v + j.nv))
                jid = m.parents[jid]
        self._cols = np.array(sorted(cols), dtype=int)
        # the chain's one-coordinate joints with finite limits: (velocity index, q index, lo, hi)
        lim = []
        for c in self._cols:
            jid = next(j for j in range(1, m.njoints) if m.joints[j].idx_v <= c < m.joints[j].idx_v + m.joints[j].nv)
            j = m.joints[jid]
            if j.nq == 1 and j.nv == 1:
                lo, hi = robot.q_min[j.idx_q], robot.q_max[j.idx_q]
                if np.isfinite(lo) and np.isfinite(hi) and hi > lo:
                    lim.append((c, j.idx_q, lo, hi))
        self._lim = tuple(lim)

    def _ready(self, robot) -> None:
        if self._fid is None or self._data is None:
            self.bind(robot)

    def manipulability(self, robot, q: np.ndarray | None = None) -> tuple[float, np.ndarray]:
        """(w_p, ∇w_p) at ``q`` (default the robot's state; w itself with ``limit_penalty``
        0); the gradient over the velocity coordinates (nv; units of w per rad), zero off the
        joints that move the frame."""
        self._ready(robot)
        m, d, fid, cols, sel = robot.model, self._data, self._fid, self._cols, self._sel
        q = robot.q if q is None else q
        grad = np.zeros(robot.nv)
        if len(cols) == 0:
            return 0.0, grad
        if self.com:
            J = pin.jacobianCenterOfMass(m, d, q)[:, cols]
        else:
            J = pin.computeFrameJacobian(m, d, q, fid, pin.LOCAL)[sel][:, cols]
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        p = len(s)
        if p < len(sel):                 # fewer joints than rows: det(J Jᵀ) = 0, w = 0
            return 0.0, grad
        w = float(np.prod(s))
        # Π_{l≠k} σ_l without dividing by σ_k (finite at σ_k = 0)
        others = np.array([np.prod(np.delete(s, k)) for k in range(p)])
        e = np.zeros(robot.nv)
        if self.com:
            # Σ_k (Π_{l≠k} σ_l) u_kᵀ ∂(J v_k)/∂q_i, with ∂(J v_k)/∂q from pinocchio at q̇ = v_k
            for i in range(p):
                e[cols] = Vt[i]
                pin.centerOfMass(m, d, q, e)
                grad[cols] += others[i] * (U[:, i] @ pin.getCenterOfMassVelocityDerivatives(m, d)[:, cols])
            e[:] = 0.0
        for c in ([] if self.com else cols):
            e[c] = 1.0
            pin.computeJointJacobiansTimeVariation(m, d, q, e)
            dJ = pin.getFrameJacobianTimeVariation(m, d, fid, pin.LOCAL)[sel][:, cols]
            e[c] = 0.0
            grad[c] = float(np.sum(others * np.einsum("ik,ij,jk->k", U, dJ, Vt.T)))
        k = self.limit_penalty
        if k > 0.0 and self._lim:
            # w_p = w P, ∇w_p = P ∇w + w ∇P, ∂P/∂q_i = P/f_i ∂f_i/∂q_i (products without a division by f_i)
            f = np.empty(len(self._lim))
            df = np.empty(len(self._lim))
            for i, (_, iq, lo, hi) in enumerate(self._lim):
                r2 = (hi - lo) ** 2
                si = (q[iq] - lo) * (hi - q[iq]) / r2
                if si > 0.0:
                    e = np.exp(-k * si)
                    f[i], df[i] = 1.0 - e, k * e * (hi + lo - 2.0 * q[iq]) / r2
                else:
                    f[i], df[i] = 0.0, 0.0
            P = float(np.prod(f))
            grad *= P
            floor = w + self.threshold
            for i, (c, _, _, _) in enumerate(self._lim):
                grad[c] += floor * float(np.prod(np.delete(f, i))) * df[i]
            w = floor * P - self.threshold
        return w, grad

    def error(self, robot) -> np.ndarray:
        """[w_min − w] below the threshold, [0] above it (m^p)."""
        w, _ = self._state(robot)
        return np.array([max(self.threshold - w, 0.0)])

    def error_units(self, robot) -> tuple[str, ...]:
        p = int(np.sum(self._sel < 3))
        return (f"m^{p}" if p else "unitless",)

    def _state(self, robot) -> tuple[float, np.ndarray]:
        q = robot.q
        got = self._last
        if got is not None and got[0] is not None and np.array_equal(got[0], q):
            return got[1], got[2]
        w, g = self.manipulability(robot, q)
        self._last = (q.copy(), w, g)
        return w, g

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        slot = eq_rows(out, 1, layout.nx)
        A, b = slot.A, slot.b
        A[:] = 0.0
        b[:] = 0.0
        w, g = self._state(robot)
        if w < self.threshold:
            v = robot.v
            kp, kd = self.gain_vectors(1)
            h = CURVATURE_STEP
            _, gp = self.manipulability(robot, pin.integrate(robot.model, robot.q, h * v))
            _, gm = self.manipulability(robot, pin.integrate(robot.model, robot.q, -h * v))
            curvature = float((gp - gm) @ v) / (2.0 * h)
            A[0, :layout.nv] = g
            b[0] = kp[0] * (self.threshold - w) - kd[0] * float(g @ v) - curvature
        return Rows(A=A, b=b)

    def params(self) -> dict:
        p = super().params()
        p.update(frame=self.frame, threshold=self.threshold, mask=self.mask, limit_penalty=self.limit_penalty)
        return p
