"""NullSpaceImpedance: a compliant impedance on what every higher level leaves free (5.43-5.44),
for a floating base with contacts.

Put it as the lowest level, alone, under the tasks it protects (a :class:`~wbc.tasks.Frame`
on ``frame``, the glass; a CoM task on a humanoid: ``protect: [com]``). What it protects
must be held by a higher level (a scenario refuses it otherwise, :func:`check_in_stack`):
it leaves those directions to them and decides every other one. Math below in the
notation of :mod:`wbc.null_space`; M is the chapter's B, τ_e the external generalised force
applied *to* the robot (the chapter's −τ_ext of 5.38).

Dynamics with rigid contacts (5.26, 5.38), J_c the contacts' Jacobian (and, on a
differential drive, the lateral-velocity row), λ their forces:

    M q̈ + h = Sᵀτ + J_cᵀ λ + τ_e,     J_c q̈ + J̇_c q̇ = 0.                         (1)

What the levels above fix. Stack the Jacobians of the contacts, of ``frame`` (6 rows),
of each ``protect`` entry (a frame: 6 rows; ``com``: 3) and of the lateral row:
J_H (its rows in any frame or order: only ker J_H matters). The solvers meet the higher
levels exactly, so q̈ is free in ker J_H only. With Z = N_H Z₀ (N_H = I − J_H⁺J_H, Z₀ an
orthonormal basis of ker J_H at the first cycle), ν = Z# q̇ and (N2)-(N4),

    ν̇ = Z# q̈ + Ż# q̇,   Z# = Λ_ν⁻¹ Zᵀ M,   Λ_ν = Zᵀ M Z.                           (2)

Constrained dynamics on that null space. Z ⊂ ker J_c, so Zᵀ J_cᵀ λ = 0: the contact forces
vanish from Zᵀ·(1), and with (N5) the acceleration answers an external torque with
δq̈ = M_c⁻¹ τ_e, of which the null space sees

    δν̇ = Z# M_c⁻¹ τ_e = Λ_ν⁻¹ Zᵀ τ_e,                                              (3)

(5.41 with the constrained inertia) while every higher task x_k (J_k Z = 0) sees
δẍ_k = J_k M_c⁻¹ τ_e (5.42 with M_c⁻¹ for M⁻¹). Decoupling: a torque in the dynamically
consistent null space of all higher levels, τ_e = Pᵀτ₀ with Pᵀ = Z#ᵀ Zᵀ = M Z Λ_ν⁻¹ Zᵀ,
gives δq̈ = M_c⁻¹ M Z Λ_ν⁻¹ Zᵀ τ₀ = Z Λ_ν⁻¹ Zᵀ τ₀: it moves ν only, and J_k δq̈ = 0, J_c δq̈ = 0
(tested on random states of Talos on two feet against pinocchio's constraintDynamics).

Rows (5.39, 5.43). The task asks

    Z# q̈ = ν̇_c − Ż# q̇,   ν̇_c = Λ_ν⁻¹ ((μ_ν + B_ν) ν̃ + Zᵀ k_q q̃ + Zᵀ τ̂_e),           (4)

with ν̃ = −ν (ν_d = 0), q̃ = q_d ⊖ q on the joints (no spring on a floating or planar root),
τ̂_e the external torque the controller was told of (``RobotModel.external_torque``,
:mod:`wbc.interaction.external_force`; 0 when none). Its r = n − rank J_H rows are exactly the freedom
the higher levels leave (q̈ = q̈₀ + Z w ⇒ Z# q̈ = Z# q̈₀ + w), so it is met exactly and
changes nothing above it. The solvers get (4) times Lᵀ (Λ_ν = L Lᵀ, Cholesky):
L⁻¹ Zᵀ M q̈ = L⁻¹ ((μ_ν + B_ν) ν̃ + Zᵀ (k_q q̃ + τ̂_e)) − Lᵀ Ż# q̇. The same solution when the
rows can be met; when an active bound above (a joint limit) takes part of the null space
away, the least-squares compromise ‖Lᵀ(Z# q̈ − ν̇_c + Ż# q̇)‖² = δq̈ᵀ M δq̈ (δq̈ the null-space
acceleration error) is Gauss's least constraint in the kinetic metric: the other joints take
what a physical stop there would pass them, no more (in ν̇ units the light modes, a gripper
at 1e-3 kg·m², claim thousands of rad/s² from the others; measured in the tests).

In closed loop, the controller's model holds τ̂_e (it is in
h, :class:`~wbc.robot.model.RobotModel`), the plant the true τ_e, so by (3)

    Λ_ν ν̃̇ + (μ_ν + B_ν) ν̃ + Zᵀ k_q q̃ = −Zᵀ τ_e            (5.44; sign: τ_e = −τ_ext)

whether or not τ̂_e is known: the null space yields to the push with the inertia Λ_ν,
damping B_ν and the projected spring. The higher tasks (each a PD, 5.16) see

    ë_k + K_d,k ė_k + K_p,k e_k = −J_k M_c⁻¹ (τ_e − τ̂_e),                            (5)

i.e. multiplied by Λ_k = (J_k M_c⁻¹ J_kᵀ)⁻¹ the task impedance 5.45-5.46 with the
constrained inertia, stiffness Λ_k K_p,k and right side J_k^{#}ᵀ(τ_e − τ̂_e),
J_k^{#} = M_c⁻¹ J_kᵀ Λ_k. Without knowledge of the push (τ̂_e = 0, the chapter's 5.46 as
written) the glass takes the push's part outside the null space, J_k M_c⁻¹ τ_e ≠ 0 for a
push on the elbow (on a floating base the whole body answers it); with τ̂_e the true push
or the momentum observer's estimate the glass sees only the error τ_e − τ̂_e and the
elbow still yields in the null space.

The terms come from :mod:`wbc.null_space`; J̇ (``computeJointJacobiansTimeVariation``),
J̇_com (``computeCentroidalMapTimeVariation``: its linear rows are m J̇_com) and C(q, q̇)
(``computeCoriolisMatrix``) are computed on the task's own pinocchio Data. When the rank of
J_H changes (a contact added or removed, a singularity) Z₀ is taken again at that cycle
(counted in ``rebases``).

Damping. ``B_nu`` is the chapter's B_ν (N·m·s/rad, B_ν = b I_r for a number, or r × r).
On a humanoid the null space holds directions of very different inertia (Talos: Λ_ν from
1e-3 kg·m², a gripper, to 2 kg·m², the torso): a uniform b = 3 N·m·s/rad makes the light
ones decay in Λ_ν/b ≈ 0.3 ms, less than a control period, and the sampled loop ν_{k+1} =
(1 − Δt Λ_ν⁻¹B_ν) ν_k diverges once Δt·λ_max(Λ_ν⁻¹B_ν) > 2. ``zeta`` instead gives every
mode of Λ_ν ν̈ + B_ν ν̇ + K_ν ν = 0, K_ν = Zᵀ k_q Z, the damping ratio ζ:

    B_ν = 2ζ L S Lᵀ,   S = (L⁻¹ K_ν L⁻ᵀ)^½,   Λ_ν = L Lᵀ,                            (6)

recomputed every cycle (its modes' frequencies √(k_q/Λ) stay far below 1/Δt).

Parameters: ``frame`` (the protected frame; optional), ``protect`` (more protected frames
or ``"com"``; a frame is protected in all 6 axes, so its task should hold all 6 that move),
``k_q`` (N·m/rad, scalar or one per joint), ``B_nu`` (N·m·s/rad, scalar or
r × r; default 3) or ``zeta`` (damping ratio), ``target`` (the posture q_d, nq; default the
configuration at the first cycle).
``error`` returns Z# q̃ (rad), the posture error seen in the null space.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
from scipy.linalg import solve_triangular

from wbc.validation.inputs import finite_vector
from wbc.validation.schema import found, is_number, matrix, number, text, vector

from ..errors import TargetError, TaskDefinitionError
from ..null_space import NullSpaceTerms, null_basis_at, null_space_terms
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, as_vector, eq_rows, gain

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: largest k_q (N·m/rad) and B_ν entry (N·m·s/rad): far stiffer than any joint, and far from
#: where (6)'s eigen-decomposition and the rows' products overflow
MAX_IMPEDANCE = 1e9


class NullSpaceImpedance(Task):
    """Compliant impedance on what every higher level (contacts, ``frame``, ``protect``)
    leaves free (5.43-5.44): the body yields to external torques where those tasks do not care.

    See the module docstring for the rows and parameters.

    Args:
        frame: the protected frame (alias or URDF name), held by a higher task; None: none.
        k_q: joint stiffness k_q of the posture spring (N·m/rad, in [0, 1e9]): a number or one
            per non-root joint; default 20.
        B_nu: the null-space damping B_ν (N·m·s/rad, entries up to 1e9): a number b (B_ν = b I_r)
            or an r × r symmetric positive definite matrix; None: 3, unless ``zeta`` is given.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; None: ``"<frame>_null_space"`` or
            ``"null_space_impedance"``.
        target: the posture q_d (nq; rad, m); None: the configuration at the first cycle.
        protect: more protected frames, or ``"com"`` (a list; a frame is protected in all 6
            axes); default none.
        zeta: damping ratio ζ of every null-space mode, (6) (unitless, in (0, 10]), instead of
            ``B_nu`` (giving both is a TaskDefinitionError); None: ``B_nu``.
    """

    kind = "null_space_impedance"

    def __init__(self, frame: str | None = None, k_q=20.0, B_nu=None, weight: float = 1.0, name: str | None = None,
                 target=None, protect=(), zeta: float | None = None) -> None:
        if frame is not None:
            text(frame, "frame", what="a frame name or alias", error=TaskDefinitionError,
                 owner="task 'null_space_impedance'")
        super().__init__(name or (f"{frame}_null_space" if frame is not None else "null_space_impedance"), weight)
        self.frame = frame
        owner = f"task '{self.name}'"
        if isinstance(protect, str) or not isinstance(protect, (list, tuple)):
            raise TaskDefinitionError(f"must be a list of frame names or 'com', got {found(protect)}",
                                      key="protect", owner=owner)
        self.protect = [text(p, f"protect[{i}]", what="a frame name or alias, or 'com'",
                             error=TaskDefinitionError, owner=owner) for i, p in enumerate(protect)]
        self.k_q = gain(self.name, "k_q", k_q)
        if np.max(self.k_q) > MAX_IMPEDANCE:
            raise TaskDefinitionError(f"must be at most {MAX_IMPEDANCE:g} N·m/rad (every entry), got "
                                      f"{float(np.max(self.k_q)):g}", key="k_q", owner=owner)
        if zeta is not None and B_nu is not None:
            raise TaskDefinitionError("give either B_nu (a damping, N·m·s/rad) or zeta (a damping ratio), not both",
                                      key="zeta", owner=owner)
        self.zeta = None if zeta is None else number(zeta, "zeta", gt=0, le=10, unit="unitless",
                                                      error=TaskDefinitionError, owner=owner)
        B_nu = 3.0 if B_nu is None else B_nu
        if is_number(B_nu) or (isinstance(B_nu, np.ndarray) and B_nu.ndim == 0):
            B = np.asarray(number(B_nu, "B_nu", gt=0, le=MAX_IMPEDANCE, unit="N·m·s/rad", error=TaskDefinitionError,
                                  owner=owner))
        else:
            B = matrix(B_nu, "B_nu", unit="N·m·s/rad", error=TaskDefinitionError, owner=owner)
            if B.shape[0] != B.shape[1]:
                raise TaskDefinitionError(f"must be a number or a square matrix, got shape {B.shape}", key="B_nu",
                                          owner=owner)
            if np.abs(B).max() > MAX_IMPEDANCE:
                raise TaskDefinitionError(f"entries must be at most {MAX_IMPEDANCE:g} N·m·s/rad in size", key="B_nu",
                                          owner=owner)
            if not np.allclose(B, B.T) or np.linalg.eigvalsh(B).min() <= 0:
                raise TaskDefinitionError("B_nu must be symmetric positive definite", owner=owner)
        self.B_nu = B
        if target is not None:      # its length (nq) is checked against the robot at bind
            target = vector(target, "target", unit="rad", error=TargetError, owner=owner) \
                if isinstance(target, (list, tuple)) else finite_vector(owner, "target", target, np.size(target))
        self._pending = target
        self.target: np.ndarray | None = None
        self._fids: list[int] = []
        self._com = False
        self._Z0: np.ndarray | None = None
        self._data: Any = None              # pinocchio Data of the bound robot (bind)
        self._kq_vec: np.ndarray | None = None
        #: times Z₀ was taken again because the rank of the higher levels' Jacobian changed
        self.rebases = 0
        self.last: NullSpaceTerms | None = None

    def bind(self, robot) -> None:
        self._com = "com" in self.protect
        frames = ([self.frame] if self.frame is not None else []) + [p for p in self.protect if p != "com"]
        self._fids = list(dict.fromkeys(robot.frame_id(f) for f in frames))
        self._data = robot.model.createData()
        r = robot.nv - self._rank_without_contacts(robot)
        if r < 1:
            raise TaskDefinitionError(f"task '{self.name}': robot '{robot.name}' has {robot.nv} DoF: no null space "
                                      f"left by {', '.join(frames + (['com'] if self._com else [])) or 'nothing'}")
        self._check_B(robot, r, " (the null space of the protected tasks; contacts make it smaller)", at_most=True)
        kq = np.zeros(robot.nv)
        kq[robot.joint_idx] = self.k_q if np.ndim(self.k_q) == 0 else \
            as_vector(self.name, "k_q", self.k_q, len(robot.joint_idx))
        self._kq_vec = kq
        if self._pending is not None:
            self.target = as_vector(self.name, "target", self._pending, robot.nq)

    def protected(self) -> list[str]:
        """The frames (and ``"com"``) this task works in the null space of: each must be held
        by a task of a higher level (:func:`check_in_stack`)."""
        return ([self.frame] if self.frame is not None else []) + list(self.protect)

    def _rank_without_contacts(self, robot) -> int:
        J = [robot.frame_jacobian(f, LWA) for f in self._fids] + ([robot.com_jacobian] if self._com else [])
        return int(np.linalg.matrix_rank(np.vstack(J))) if J else 0

    def _check_B(self, robot, r: int, why: str, at_most: bool = False) -> None:
        """B_nu (a matrix) against the null space's dimension r: equal, or (``at_most``, at
        bind, before the contacts are known) no larger."""
        if self.B_nu.ndim == 2 and (self.B_nu.shape[0] > r if at_most else self.B_nu.shape != (r, r)):
            raise TaskDefinitionError(f"task '{self.name}': B_nu must be {'at most ' if at_most else ''}{r} × {r} "
                                      f"for robot '{robot.name}'{why}")

    # ------------------------------------------------------------------ rows
    def stacked_jacobian(self, robot, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
        """(J_H, J̇_H): the contacts of ``layout``, ``frame``, ``protect`` and the lateral row
        of a differential drive, world-aligned, at the robot's cached state."""
        m, d, q, v = robot.model, self._data, robot.q, robot.v
        pin.computeJointJacobiansTimeVariation(m, d, q, v)
        pin.updateFramePlacements(m, d)
        J, Jd = [], []
        for surf in layout.surfaces.values():
            fid = robot.frame_id(surf.frame)
            k = 6 if surf.kind == "surface" else 3
            J.append(robot.frame_jacobian(fid, LWA)[:k])
            Jd.append(pin.getFrameJacobianTimeVariation(m, d, fid, LWA)[:k])
        for fid in self._fids:
            J.append(robot.frame_jacobian(fid, LWA))
            Jd.append(pin.getFrameJacobianTimeVariation(m, d, fid, LWA))
        if self._com:
            J.append(robot.com_jacobian)
            pin.computeCentroidalMapTimeVariation(m, d, q, v)
            Jd.append(d.dAg[:3] / robot.mass)          # linear rows of dA_g = m J̇_com
        if robot.differential_drive:
            e = np.zeros((1, robot.nv))
            e[0, 1] = 1.0                               # planar v_y: the base's lateral velocity
            J.append(e)
            Jd.append(np.zeros_like(e))
        return np.vstack(J), np.vstack(Jd)

    def terms(self, robot, layout: Layout) -> NullSpaceTerms:
        """The null-space terms (2) at the robot's cached state (Z₀ taken at the first call,
        and again when the rank of J_H changes)."""
        if self._data is None:
            self.bind(robot)
        if self.target is None:
            self.target = robot.q.copy()
        J, Jd = self.stacked_jacobian(robot, layout)
        C = pin.computeCoriolisMatrix(robot.model, self._data, robot.q, robot.v)
        if self._Z0 is None:
            self._Z0 = null_basis_at(J)
        T = null_space_terms(robot.M, C, robot.v, J, Jd, self._Z0)
        if T.rank + self._Z0.shape[1] != robot.nv:
            self._Z0 = null_basis_at(J)
            self.rebases += 1
            T = null_space_terms(robot.M, C, robot.v, J, Jd, self._Z0)
        if self._Z0.shape[1] == 0:
            raise TaskDefinitionError(f"task '{self.name}': the higher levels leave no null space "
                                      f"(rank {T.rank} of {robot.nv})")
        self._check_B(robot, self._Z0.shape[1], " (the null space of the contacts and protected tasks)")
        return T

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        T = self.terms(robot, layout)
        r = T.Z.shape[1]
        slot = eq_rows(out, r, layout.nx)
        A, b = slot.A, slot.b
        L = np.linalg.cholesky(T.Lambda_nu)                          # Λ_ν = L Lᵀ
        A[:, : layout.nv] = solve_triangular(L, T.Lambda_nu @ T.Zsharp, lower=True)     # Lᵀ Z# = L⁻¹ Zᵀ M
        nu_t = -(T.Zsharp @ robot.v)
        q_t = robot.difference(robot.q, self.target)
        B = self.damping(T) if self.zeta is not None else self.B_nu * np.eye(r) if self.B_nu.ndim == 0 else self.B_nu
        drive = (T.mu_nu + B) @ nu_t + T.Z.T @ (self._kq_vec * q_t + robot.external_torque)
        b[:] = solve_triangular(L, drive, lower=True) - L.T @ T.Zsharp_dot_v                  # (4) times Lᵀ
        self.last = T
        return Rows(A=A, b=b)

    def damping(self, T: NullSpaceTerms) -> np.ndarray:
        """B_ν = 2ζ L S Lᵀ, S = (L⁻¹ K_ν L⁻ᵀ)^½, Λ_ν = L Lᵀ, K_ν = Zᵀ k_q Z: every mode of
        Λ_ν ν̈ + B_ν ν̇ + K_ν ν = 0 has the damping ratio ζ (module docstring)."""
        L = np.linalg.cholesky(T.Lambda_nu)
        Li_Z = np.linalg.solve(L, T.Z.T)
        w, V = np.linalg.eigh((Li_Z * self._kq_vec) @ Li_Z.T)
        LV = L @ V
        zeta = self.zeta
        if zeta is None:
            raise TaskDefinitionError(f"task '{self.name}': damping(T) needs zeta (B_nu is given)")
        return 2.0 * zeta * (LV * np.sqrt(np.clip(w, 0.0, None))) @ LV.T

    def error(self, robot) -> np.ndarray | None:
        if self.last is None or self.target is None:
            return None
        return self.last.Zsharp @ robot.difference(robot.q, self.target)

    def error_units(self, robot) -> tuple[str, ...]:
        """The null-space coordinates ν = Z# (q_d ⊖ q): combinations of joint coordinates,
        rad on a robot with revolute joints only (m and rad mixed otherwise: ``"rad|m"``)."""
        units = set(robot.velocity_units())
        unit = "rad" if units == {"rad"} else "rad|m"
        return (unit,) * (0 if self.last is None else self.last.Zsharp.shape[0])

    def params(self) -> dict:
        p: dict[str, Any] = {"k_q": self.k_q if np.ndim(self.k_q) == 0 else list(np.atleast_1d(self.k_q))}
        if self.frame is not None:
            p["frame"] = self.frame
        if self.zeta is not None:
            p["zeta"] = self.zeta
        else:
            p["B_nu"] = float(self.B_nu) if self.B_nu.ndim == 0 else self.B_nu.tolist()
        if self.protect:
            p["protect"] = list(self.protect)
        p.update(super().params())
        if self.target is not None:
            p["target"] = self.target.tolist()
        return p


def check_in_stack(stack, robot) -> list[tuple[str, str, str]]:
    """What a stack's NullSpaceImpedance tasks get wrong, as (task name, key, message): a
    ``frame``/``protect`` entry no higher level holds (a frame task on that frame, a com task
    for ``"com"``: a direction left to nobody, which the solver would let drift), no null space
    left by the stack's contacts and protected tasks, or a ``B_nu`` matrix of the wrong size
    for that null space (at the robot's current state)."""
    problems = []
    contacts = [robot.contact(c.contact) for c in stack.contacts()]
    for k, level in enumerate(stack.levels):
        for t in level:
            if not isinstance(t, NullSpaceImpedance):
                continue
            above = [u for lvl in stack.levels[:k] for u in lvl]
            held = {robot.frame_id(u.frame) for u in above if u.kind == "frame"}
            has_com = any(u.kind == "com" for u in above)
            for p in t.protected():
                if (p == "com" and not has_com) or (p != "com" and robot.frame_id(p) not in held):
                    problems.append((t.name, "protect" if p in t.protect else "frame",
                                     f"protects '{p}', which no higher level holds (add a "
                                     f"{'com' if p == 'com' else 'frame'} task on it above, or drop it)"))
            J = [robot.frame_jacobian(robot.frame_id(c.frame), LWA)[: 6 if c.kind == "surface" else 3]
                 for c in contacts]
            J += [robot.frame_jacobian(robot.frame_id(f), LWA) for f in t.protected() if f != "com"]
            J += [robot.com_jacobian] if "com" in t.protected() else []
            if robot.differential_drive:
                J.append(np.eye(1, robot.nv, 1))
            r = robot.nv - (int(np.linalg.matrix_rank(np.vstack(J))) if J else 0)
            if r < 1:
                problems.append((t.name, "protect", f"the contacts and the protected tasks leave no null space "
                                                     f"(rank {robot.nv - r} of {robot.nv})"))
            elif t.B_nu.ndim == 2 and t.B_nu.shape != (r, r):
                problems.append((t.name, "B_nu", f"must be {r} × {r} (the null space of the contacts and the "
                                                 f"protected tasks), got {t.B_nu.shape[0]} × {t.B_nu.shape[1]}"))
    return problems
