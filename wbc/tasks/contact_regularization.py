"""ContactRegularization: decide the contact-force directions that no other task decides.

With more than one contact, the stack's equations leave part of the contact forces free.
The floating-base rows of the equation of motion (5.26),

    J_uᵀ f = S_u (M q̈ + h),      J_u = J_f[:, u]  (u: the root's 6 coordinates),

fix the total wrench the contacts exert on the robot, not how it is shared: every
f + f_int with J_uᵀ f_int = 0 (an *internal force*: the two feet squeezing or pulling the
ground apart, twisting against each other, one sole's normal force traded for the other's
centre of pressure) gives the same motion. Two soles carry 12 force variables and 6 of
them are internal. A task that does not act on forces (CoM, hands, posture) has no say on
them, so in the recursive projection (5.25) they are the null-space term N η of (5.13)
that nothing chooses: a least-norm choice from 0 keeps the normal load equal and carries
every moment by the soles' torques (cheap in N·m next to the forces in N), which pushes
the CoPs to the sole edges as soon as the CoM leaves the middle; a choice from the
previous cycle's solution (a warm start) lets them drift. A real robot then slips
(squeeze) or rolls on a sole edge (CoP).

This task chooses them, deterministically and from the state only. Its rows act on the
force variables of every contact in the stack, each in its own frame (N and N·m at the
surface's centre, :class:`~wbc.tasks.Contact`), and are all in N:

    sole (half length X, half width Y, ρ = √(X² + Y²)):
        f_x = 0,   f_y = 0,   β f_z = 0,   τ_x / Y = 0,   τ_y / X = 0,   τ_z / ρ = 0
    point contact:
        f_x = 0,   f_y = 0,   β f_z = 0

i.e. min Σ_c ‖W_c f_c‖² with W_c = diag(1, 1, β, 1/Y, 1/X, 1/ρ): each wrench in N, its
moments as the force at the sole's edge that would produce them. The centre of pressure
of a sole is p = (−τ_y, τ_x) / f_z, so τ_x / Y = f_z · p_y / Y is the normal force times the
CoP's offset as a fraction of the half width: the rows pull each CoP to its surface's
centre, the tangential forces to an equal share (no internal squeeze), the yaw torques to
zero, and the normal forces to an equal share, β (``normal_weight``, dimensionless)
weighing that share against the CoP offsets. β = 1 is the regularisation of the four
corner forces of a sole (Σ_i ‖f_i‖² = f_z²/4 + τ_x²/4Y² + τ_y²/4X² + ...). Two soles side
by side trade normal force for CoP offsets: β → 0 puts every CoP at its centre and the
load wherever the total moment puts it, so a sole is unloaded as soon as the ZMP passes
the other sole's centre; a larger β keeps both loaded and moves the CoPs out, up to the
``cop_margin`` rectangle of level 0. Measured at the extremes of ``talos_balance``'s sway
(±5 cm at 0.5 Hz, ZMP 9.3 cm out, soles' centres 8.5 cm out): β = 0.1 and 0.5 unloaded a
foot (0 N), β = 1 kept 33 N on it with up to 12 N of internal force where its friction
cone was full, β = 2 (default) kept 121 N and no internal force (< 1e-4 N); the CoPs stayed
on or inside the margin rectangle in every case. Point contacts have only the force rows.

Placed below every other level (the controller adds one, :class:`~wbc.Controller`'s
``contact_regularization``, when the stack has contacts and no such task and not every
contact has a :class:`~wbc.tasks.ContactWrench` target), it minimises this only over the
directions the levels above left free. When those are the internal forces (q̈ decided
above, as with a posture task), the solution is the weighted least-norm distribution of
the total wrench w = S_u(M q̈ + h),

    f = W⁻² J_u (J_uᵀ W⁻² J_u)⁻¹ w           (5.13 with weight W², on the grasp map J_uᵀ),

the nominal distribution: no internal force in the metric W, the CoPs towards their
surfaces' centres and the normal load towards equal shares as far as the total wrench
allows. For Talos standing (soles 0.17 m apart, X = 0.1 m, Y = 0.065 m) with the CoM moved
5 cm to one side, at rest: normal forces 366 and 520 N, τ_x = 15 N·m on each sole (CoP
offsets 4.2 and 2.9 cm), no tangential force; with β = 1, 281 and 605 N (CoPs 2.9 and
1.3 cm out); with β = 0.1, 188 and 698 N with the CoPs within 1 mm of the centres; the
least-norm choice from 0, about 440 N each with both CoPs 4.9 cm out, 1.6 cm from the
edge (and at the sway's extremes past it). The contacts' friction cones and CoP bounds
(level 0) still hold: where the nominal distribution would leave them, the solvers keep
the level-0 inequalities and this task is met as closely as they allow.

:func:`nominal_forces` is the same distribution with q̈ = 0 (gravity and velocity terms
only): the point the hierarchical solvers start each cycle's least-norm choices from (a
function of the state, never of the previous cycle).

``weight`` (dimensionless): relative to other tasks in its level; ``normal_weight`` β.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.validation.schema import number

from ..cholesky import cholesky_lower
from ..errors import TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, eq_rows

#: smallest sole half size (m) the moment rows divide by
MIN_HALF_SIZE = 1e-3


class ContactRegularization(Task):
    """Every contact's wrench towards the nominal distribution (module docstring): rows
    W_c f_c = 0 over the force variables of each contact in the stack (N).

    Args:
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        normal_weight: β, the weight of the normal forces' equal share against the CoP offsets
            (unitless, in [1e-6, 1e6]; module docstring); default 2.
        name: the task's name, unique in a stack; default ``"contact_regularization"``.
    """

    kind = "contact_regularization"
    on_forces = True
    layout_only_A = True
    regularizer = True
    reads_force_jacobian = False           # W on the force variables: the layout's sizes only

    def __init__(self, weight: float = 1.0, normal_weight: float = 2.0, name: str = "contact_regularization") -> None:
        super().__init__(name, weight)
        self.normal_weight = number(normal_weight, "normal_weight", ge=1e-6, le=1e6, unit="unitless",
                                    error=TaskDefinitionError,
                                    owner=f"task '{self.name}'")
        self._w: tuple | None = None

    def force_weights(self, layout: Layout) -> np.ndarray:
        """The diagonal of W over the layout's force variables (nf; 1, 1/m), in layout order;
        rebuilt when the layout or ``normal_weight`` changes."""
        got = self._w
        if got is not None and got[0] is layout and got[1] == self.normal_weight:
            return got[3]                          # the same layout object: the same surfaces
        key = (layout.structure_key(), self.normal_weight, tuple((s.kind, s.half_length, s.half_width)
                                                                 for s in layout.surfaces.values()))
        if got is not None and got[2] == key:
            self._w = (layout, self.normal_weight, key, got[3])
            return got[3]
        w = np.zeros(layout.nf)
        for name, sl in layout.contact_slices.items():
            s = layout.surfaces.get(name)
            if s is None:
                raise TaskDefinitionError(f"task '{self.name}': the layout has no surface for contact '{name}'")
            a = sl.start - layout.nv
            w[a:a + 3] = (1.0, 1.0, self.normal_weight)
            if s.kind == "surface":
                # a sole under 1 mm is a point: its moments weighed as at 1 mm (finite rows)
                X, Y = max(s.half_length, MIN_HALF_SIZE), max(s.half_width, MIN_HALF_SIZE)
                w[a + 3:a + 6] = (1.0 / Y, 1.0 / X, 1.0 / np.hypot(X, Y))
        w.flags.writeable = False
        self._w = (layout, self.normal_weight, key, w)
        return w

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        nf, nv = layout.nf, layout.nv
        slot = eq_rows(out, nf, layout.nx)
        A, b = slot.A, slot.b
        w = self.force_weights(layout)
        if slot.written != id(w):          # A is written once per weights' array
            A[:] = 0.0
            A[np.arange(nf), nv + np.arange(nf)] = w
            b[:] = 0.0
            slot.written = id(w)
        return Rows(A=A, b=b)

    def error_from(self, f: np.ndarray, layout: Layout) -> np.ndarray:
        """W f (N): what the rows ask to be zero, for force vector ``f`` (nf)."""
        return self.force_weights(layout) * f

    def params(self) -> dict:
        p = super().params()
        if p["name"] == "contact_regularization":
            del p["name"]
        if self.normal_weight != 2.0:
            p["normal_weight"] = self.normal_weight
        return p


@nb.njit(cache=True)
def reference_point(x, nv, idx, lo, hi, margin, Jf, h, u, w):
    """The hierarchical solvers' reference x₀ = (q̈₀, f₀), written into ``x`` (nx): q̈₀ = 0
    where the joint-acceleration bounds lo ≤ q̈[idx] ≤ hi allow it, else the bound 0 is
    beyond moved ``margin`` inside (min(margin, ¼ of their range): a point on a bound sends
    the next level's step across it); f₀ = :func:`nominal_forces` (skipped when there is no
    force, or no root to carry: ``u`` empty)."""
    for j in range(idx.shape[0]):
        d = min(margin, 0.25 * (hi[j] - lo[j]))
        if lo[j] > 0.0:
            x[idx[j]] = min(lo[j] + d, hi[j])
        elif hi[j] < 0.0:
            x[idx[j]] = max(hi[j] - d, lo[j])
        else:
            x[idx[j]] = 0.0
    if Jf.shape[0] and u.shape[0]:
        x[nv:] = nominal_forces(Jf, h, u, w)


@nb.njit(cache=True)
def nominal_forces(Jf, h, u, w):
    """The nominal distribution with q̈ = 0: argmin ‖diag(w) f‖² s.t. J_f[:, u]ᵀ f = h[u]
    (the root's rows of 5.26 at rest: the contacts carry gravity and the velocity terms),
    f = D B (Bᵀ D B)⁻¹ h_u with B = J_f[:, u], D = diag(w)⁻² (N, N·m; zeros when u is empty
    or there is no force). G = Bᵀ D B (6 × 6 for a free flyer) is solved by Cholesky, in
    place and without LAPACK (2 µs less than an eigen-decomposition, the call being the
    cost); when it is singular to 1e-12 of its diagonal (contacts that cannot carry some
    component of the wrench: a single point contact) by its pseudo-inverse; zeros for a
    non-finite state (the cycle then fails on its own)."""
    nf = Jf.shape[0]
    nu = u.shape[0]
    f = np.zeros(nf)
    if nf == 0 or nu == 0:
        return f
    DB = np.empty((nf, nu))
    for i in range(nf):
        ww = w[i] * w[i]
        d = 1.0 / ww if ww > 0.0 else 0.0
        for j in range(nu):
            DB[i, j] = d * Jf[i, u[j]]
    G = np.zeros((nu, nu))
    for a in range(nu):
        ua = u[a]
        for b in range(a + 1):
            t = 0.0
            for i in range(nf):
                t += Jf[i, ua] * DB[i, b]
            G[a, b] = t
            G[b, a] = t
    y = np.empty(nu)
    for j in range(nu):
        y[j] = h[u[j]]
    if not (np.all(np.isfinite(G)) and np.all(np.isfinite(y))):
        return f                                  # a non-finite state: no reference (0)
    big = 0.0
    for j in range(nu):
        big = max(big, G[j, j])
    ok = big > 0.0
    if ok:
        L, ok = cholesky_lower(G, 1e-12 * big)
    if ok:
        for i in range(nu):                       # L v = h_u, then Lᵀ y = v
            for p in range(i):
                y[i] -= L[i, p] * y[p]
            y[i] /= L[i, i]
        for i in range(nu - 1, -1, -1):
            for p in range(i + 1, nu):
                y[i] -= L[p, i] * y[p]
            y[i] /= L[i, i]
    else:
        ev, V = np.linalg.eigh(G)
        cut = 1e-12 * max(ev[nu - 1], 0.0)
        c = V.T @ y
        for j in range(nu):
            c[j] = c[j] / ev[j] if ev[j] > cut else 0.0
        y = V @ c
    for i in range(nf):
        t = 0.0
        for j in range(nu):
            t += DB[i, j] * y[j]
        f[i] = t
    return f
