"""Force: track a contact force along chosen directions with measured-force feedback (5.3.3).

The contact task ``contact`` (its name in the stack) owns the force variables f of x = (q̈, f)
(3 for a point contact, world-aligned axes; 6 for a surface, (f, τ) in its LOCAL frame, as
:class:`~wbc.tasks.Contact` defines them; the force the environment applies to the robot).
``directions`` picks the m controlled directions of that force space, the columns of an
orthonormal S_f (d × m): the chapter's λ = S_fᵀ h (5.31), by default the contact normal
(λ the normal force, N). The rows are

    S_fᵀ f = f_λ,       f_λ = λ_D + K_P (λ_D − λ_m) + K_I ∫ (λ_D − λ_m) dt            (5.3.3)

with λ_m = S_fᵀ f_m the measured force: the chapter's f_λ with both its feedback terms (P
reduces the effect of disturbance forces, the integral removes a constant bias). Over x the
rows touch only the force columns, so they hold with every solver that takes force rows:
``hqp`` and ``weighted`` meet them as any other level's rows; ``projection`` solves q̈
without them and meets them in its force distribution (a least-squares target below the root
dynamics, inside the friction cones: exact on a fixed or actuated base, as close as the
dynamics and the cones allow on a floating one).

What makes the commanded force the applied one is the contact being rigid: the contact
task's rows hold the normal acceleration at its reference, so (with an exact model) the
environment reacts with the f the torques τ = S_a(M q̈ + h − J_fᵀ f) assumed. The feedback
corrects what the model does not know (a payload, a soft contact, friction in the joints).

Measurement: :meth:`Force.feed` gives f_m (the contact's d force components, N and N·m)
once per control period of ``dt`` s, before the solve; :mod:`wbc.interaction.force_sensing` does it in a
run, from ``source``: ``"simulator"`` (the contact force the simulator applied over the last
step, what a force sensor at the contact reads) or ``"observer"`` (the generalised-momentum
observer's τ_ext, :mod:`wbc.interaction.momentum_observer`, projected on the stack's contact
forces: no force sensor). Until the first feed the rows are pure feed-forward, f_λ = λ_D.

Discrete law per feed (h = dt; e = λ_D − λ_m; per direction):

    I ← I + e h,  clamped to |K_I I| ≤ ``integral_limit`` (anti-windup, N),
    f_λ = clip(λ_D + K_P e + K_I I, lo, hi),

lo = 0 on a direction that pushes into the surface (a positive normal component: the
contact cannot pull), −``max_force`` otherwise, hi = ``max_force``; while f_λ is clipped
and e would drive it further out, I is not advanced (conditional integration). Stability on
a rigid contact: the applied force answers the command within the period and the
measurement is one period old, so λ_k = (1 + K_P) λ_D − K_P λ_{k−1} + K_I h Σ e: K_P < 1
(0.3-0.5 leaves margin for a filtered measurement), and the integral's time constant is about
(1 + K_P) / K_I s.

``tangential``: the force components outside S_f (its orthonormal complement S_c, the
motion directions of a hybrid task): ``"free"`` (no rows: the lower levels and the contact
regularisation decide them) or ``"measured"`` (rows S_cᵀ f = S_cᵀ f_m: the environment's force
there, the friction of a sliding hand, is fed forward, so the torques account for it and
the motion task is not disturbed by it; the chapter's scheme cancels the measured h_e alike).

``motion``: the name of the motion task (a :class:`~wbc.tasks.Frame` on the contact's frame)
driving the other directions: the hybrid force/motion construct of :mod:`wbc.interaction.hybrid_selection` checks
S_fᵀ S_v = 0 (5.33) between them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from wbc.validation.schema import found, is_number, number, show, text, vector

from ..errors import StackError, TargetError, TaskDefinitionError
from ..options import Options
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, eq_rows

SOURCES = ("simulator", "observer")
TANGENTIAL = ("free", "measured")


def selection_basis(directions: np.ndarray, owner: str = "task 'force'") -> tuple[np.ndarray, np.ndarray]:
    """(S, S_⊥): an orthonormal basis of the span of the columns of ``directions`` (d × m,
    each column along the given one, QR) and of its orthogonal complement (d × (d − m), SVD),
    so Sᵀ S_⊥ = 0 and [S S_⊥] is orthogonal. Raises TaskDefinitionError for dependent columns."""
    D = np.asarray(directions, dtype=float)
    d, m = D.shape
    if m > d or np.linalg.matrix_rank(D, tol=1e-9 * max(1.0, float(np.abs(D).max()))) < m:
        raise TaskDefinitionError(f"must be linearly independent directions (at most {d}), got {show(D.T.tolist())}",
                                  key="directions", owner=owner)
    Q, R = np.linalg.qr(D)
    S = Q * np.sign(np.diag(R))
    U = np.linalg.svd(S, full_matrices=True)[0]
    return S, U[:, m:]


@dataclass(frozen=True)
class ForceFeedback(Options):
    """The measured-force feedback of a :class:`Force` task (each checked by the task)."""

    kp: float = 0.0
    """K_P of the PI feedback (unitless, in [0, 1): < 1 for a rigid contact); 0: feed-forward only"""
    ki: float = 0.0
    """K_I, 1/s (in [0, 1e4])"""
    integral_limit: float = 50.0
    """anti-windup bound on |K_I ∫e|, N (≥ 0, may be inf)"""
    max_force: float = 1000.0
    """bound on the command |λ|, N (> 0, may be inf)"""
    ramp: float = 0.0
    """duration of the quintic rise of λ_D from 0 after the first feed, s (in [0, 3600])"""
    source: str = "simulator"
    """the measurement: ``"simulator"`` (its contact force) or ``"observer"`` (the momentum observer's)"""
    observer_gain: float = 100.0
    """K_O of the momentum observer, 1/s (in (0, 1e4])"""
    tangential: str = "free"
    """the force outside S_f: ``"free"`` (no rows) or ``"measured"`` (rows S_cᵀ f = S_cᵀ f_m)"""


class Force(Task):
    """Track a contact force along S_f with measured-force PI feedback (5.3.3): rows
    S_fᵀ f = λ_D + K_P (λ_D − λ_m) + K_I ∫(λ_D − λ_m) dt on the force variables of the contact
    task ``contact`` (module docstring).

    ``target`` λ_D (N; N·m along a moment direction): a number (one direction) or m numbers.
    ``directions``: one direction (3 numbers for a point contact, 6 for a surface) or a list
    of m of them, in the contact's force axes; default the contact normal. ``kp`` K_P
    (unitless, in [0, 1)), ``ki`` K_I (1/s), ``integral_limit`` the anti-windup bound on
    |K_I ∫e| (N), ``max_force`` the command bound (N), ``ramp`` (s) the quintic rise of λ_D
    from 0 after the first feed, ``source`` ``simulator`` | ``observer`` (the measurement),
    ``observer_gain`` K_O (1/s) of the momentum observer, ``tangential`` ``free`` |
    ``measured``, ``motion`` the hybrid partner (a frame task's name).

    Args:
        contact: the name of a Contact task in the stack (``"hand_pad_contact"``).
        target: λ_D (N; N·m along a moment direction, each in [−1e5, 1e5]): a number (the same
            on every direction) or one per direction; default 10 N.
        directions: S_f, one direction (3 numbers for a point contact, 6 for a surface) or a
            list of m linearly independent ones, in the contact's force axes (unitless); None:
            the contact normal.
        motion: the name of the hybrid partner, a Frame task on the contact's frame; None: none.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; None: ``"<contact>_force"``.
        options: the feedback below in one :class:`ForceFeedback` (None: its defaults).
        **settings: its fields one by one, over ``options`` (another name is a TypeError):

        kp: K_P of the PI feedback (unitless, in [0, 1): < 1 for a rigid contact); default 0
            (feed-forward only).
        ki: K_I (1/s, in [0, 1e4]); default 0.
        integral_limit: anti-windup bound on |K_I ∫e| (N, ≥ 0, may be inf); default 50 N.
        max_force: bound on the command |λ| (N, > 0, may be inf); default 1000 N.
        ramp: duration of the quintic rise of λ_D from 0 after the first feed (s, in [0, 3600]);
            default 0 (no ramp).
        source: the measurement: ``"simulator"`` (default, its contact force) or ``"observer"``
            (the momentum observer's estimate).
        observer_gain: K_O of the momentum observer (1/s, in (0, 1e4]); default 100.
        tangential: the force outside S_f: ``"free"`` (default, no rows) or ``"measured"``
            (rows S_cᵀ f = S_cᵀ f_m, module docstring).
    """

    kind = "force"
    on_forces = True
    layout_only_A = True

    options_record = ForceFeedback

    def __init__(self, contact: str, target=10.0, directions=None, motion: str | None = None, weight: float = 1.0,
                 name: str | None = None, options: ForceFeedback | None = None, **settings) -> None:
        text(contact, "contact", what="the name of a contact task in the stack (e.g. hand_pad_contact)",
             error=TaskDefinitionError, owner="task 'force'")
        super().__init__(name or f"{contact}_force", weight)
        self.contact = contact
        owner = f"task '{self.name}'"
        o = ForceFeedback.of(options, settings, owner)
        kp, ki, integral_limit, max_force, ramp = o.kp, o.ki, o.integral_limit, o.max_force, o.ramp
        source, observer_gain, tangential = o.source, o.observer_gain, o.tangential
        self._directions = self._check_directions(directions, owner)
        #: (S_f, S_c) per contact force size: the given directions' (one size), else the normal's
        if self._directions is not None:
            self._bases = {self._directions.shape[0]: selection_basis(self._directions, owner)}
        else:
            self._bases = {d: selection_basis(np.eye(d)[:, 2:3]) for d in (3, 6)}
        m = 1 if self._directions is None else self._directions.shape[1]
        self.m = m
        self.target = target
        self.kp = number(kp, "kp", ge=0, lt=1, unit="unitless; < 1 for a rigid contact", error=TaskDefinitionError,
                         owner=owner)
        self.ki = number(ki, "ki", ge=0, le=1e4, unit="1/s", error=TaskDefinitionError, owner=owner)
        self.integral_limit = number(integral_limit, "integral_limit", ge=0, allow_inf=True, unit="N",
                                     error=TaskDefinitionError, owner=owner)
        self.max_force = number(max_force, "max_force", gt=0, allow_inf=True, unit="N",
                                error=TaskDefinitionError, owner=owner)
        self.ramp = number(ramp, "ramp", ge=0, le=3600, unit="s", error=TaskDefinitionError, owner=owner)
        self.source = text(source, "source", choices=SOURCES, error=TaskDefinitionError, owner=owner)
        self.observer_gain = number(observer_gain, "observer_gain", gt=0, le=1e4, unit="1/s",
                                    error=TaskDefinitionError, owner=owner)
        self.tangential = text(tangential, "tangential", choices=TANGENTIAL, error=TaskDefinitionError, owner=owner)
        if motion is not None:
            text(motion, "motion", what="the name of a frame task in the stack", error=TaskDefinitionError,
                 owner=owner)
        self.motion = motion
        self.reset()

    # ------------------------------------------------------------ parameters
    @staticmethod
    def _check_directions(directions, owner: str) -> np.ndarray | None:
        """``directions`` as a d × m matrix of columns (d = 3 or 6), or None (the normal)."""
        if directions is None:
            return None
        rows = directions
        if isinstance(rows, np.ndarray):
            rows = rows.tolist()
        if isinstance(rows, (list, tuple)) and rows and all(is_number(v) for v in rows):
            rows = [rows]
        if not isinstance(rows, (list, tuple)) or not rows or not all(isinstance(r, (list, tuple)) for r in rows):
            raise TaskDefinitionError("must be a direction (3 numbers for a point contact, 6 for a surface) or a "
                                      f"list of them, got {found(directions)}", key="directions", owner=owner)
        d = len(rows[0])
        cols = [vector(r, f"directions[{i}]", (3, 6) if i == 0 else d, unit="unitless", error=TaskDefinitionError,
                       owner=owner) for i, r in enumerate(rows)]
        return np.column_stack(cols)

    @property
    def target(self) -> np.ndarray:
        """λ_D (m,), N (N·m along a moment direction)."""
        return self._target

    @target.setter
    def target(self, value) -> None:
        owner = f"task '{self.name}'"
        if is_number(value):
            value = [value] * self.m
        self._target = vector(value, "target", self.m, ge=-1e5, le=1e5, unit="N", error=TargetError, owner=owner)

    def reset(self) -> None:
        """Clear the feedback state: integral (N·s), clock (s), last measurement."""
        self.integral = np.zeros(self.m)
        self.time = 0.0
        self.fed = False
        self.measured: np.ndarray | None = None
        self.command = self.reference()
        #: feeds whose command was clipped at its bounds (a fault of the force loop, counted)
        self.clipped = 0

    # ------------------------------------------------------------ the law
    def selection(self, dim: int) -> tuple[np.ndarray, np.ndarray]:
        """(S_f, S_c) for a contact of ``dim`` force components (3 or 6); StackError if the
        directions have another size."""
        got = self._bases.get(dim)
        if got is None:
            given = "?" if self._directions is None else self._directions.shape[0]
            raise StackError(f"task '{self.name}': its directions have {given} components, but "
                             f"contact task '{self.contact}' has {dim} force components (3: a point, 6: a surface)")
        return got

    def error_units(self, robot) -> tuple[str, ...]:
        """N per force direction, N·m per moment direction (a surface contact's components 3-5),
        ``"N|N·m"`` for a direction that mixes both."""
        if self._directions is None:
            return ("N",)
        D = self._directions
        if D.shape[0] == 3:
            return ("N",) * D.shape[1]
        force, moment = np.abs(D[:3]).max(axis=0) > 0, np.abs(D[3:]).max(axis=0) > 0
        return tuple("N|N·m" if f and m else ("N" if f else "N·m") for f, m in zip(force, moment))

    def reference(self) -> np.ndarray:
        """λ_D at the task's clock: the target, raised from 0 by a quintic over ``ramp`` s."""
        if self.ramp <= 0.0 or self.time >= self.ramp:
            return self._target.copy()
        s = self.time / self.ramp
        return self._target * (s * s * s * (10.0 - 15.0 * s + 6.0 * s * s))

    def _bounds(self, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo = np.where(S[2] > 1e-9, 0.0, -self.max_force)         # pushing into the surface: no pulling
        return lo, np.full(self.m, self.max_force)

    def feed(self, measured, dt: float) -> np.ndarray:
        """One control period: the measured contact force f_m (d,) over the last ``dt`` s ->
        the command f_λ (m,) of the next rows (module docstring). Returns f_λ."""
        owner = f"task '{self.name}'"
        f = np.asarray(measured, dtype=float).reshape(-1)
        if f.shape not in ((3,), (6,)) or not np.all(np.isfinite(f)):
            raise TargetError(f"must be 3 or 6 finite numbers (N, N·m), got {show(f.tolist())}", key="measured",
                              owner=owner)
        dt = number(dt, "dt", gt=0, unit="s", error=TargetError, owner=owner)
        S, _ = self.selection(len(f))
        if self.fed:
            self.time += dt
        self.fed = True
        self.measured = f.copy()
        ref = self.reference()
        e = ref - S.T @ f
        lo, hi = self._bounds(S)
        integral = self.integral + e * dt
        if self.ki > 0.0 and np.isfinite(self.integral_limit):
            cap = self.integral_limit / self.ki
            integral = np.clip(integral, -cap, cap)
        raw = ref + self.kp * e + self.ki * integral
        cmd = np.clip(raw, lo, hi)
        self.clipped += bool(np.any(cmd != raw))
        # conditional integration: no integral step that drives a saturated command further out
        held = ((raw > hi) & (e > 0)) | ((raw < lo) & (e < 0))
        integral[held] = self.integral[held]
        self.integral = integral
        self.command = cmd
        return cmd

    # ------------------------------------------------------------ rows
    def _slice(self, layout: Layout) -> slice:
        sl = layout.contact_slices.get(self.contact)
        if sl is None:
            raise StackError(f"task '{self.name}': the stack has no contact task '{self.contact}'; expected one of "
                             f"{sorted(layout.contact_slices)}")
        return sl

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        sl = self._slice(layout)
        d = sl.stop - sl.start
        S, Sc = self.selection(d)
        n = self.m + (d - self.m if self.tangential == "measured" else 0)
        slot = eq_rows(out, n, layout.nx)
        A, b = slot.A, slot.b
        key = (sl.start, sl.stop)            # A is written once per force slice
        if slot.written != key:
            A[:] = 0.0
            A[: self.m, sl] = S.T
            if n > self.m:
                A[self.m:, sl] = Sc.T
            slot.written = key
        b[: self.m] = self.command if self.fed else self.reference()
        if n > self.m:
            b[self.m:] = 0.0 if self.measured is None else Sc.T @ self.measured
        return Rows(A=A, b=b)

    def error(self, robot) -> np.ndarray:
        """λ_D − λ_m (N): the force error along S_f at the last measurement (λ_D before any)."""
        if self.measured is None:
            return self.reference()
        return self.reference() - self.selection(len(self.measured))[0].T @ self.measured

    def params(self) -> dict:
        p: dict[str, Any] = {"contact": self.contact}
        p.update(super().params())
        if p["name"] == f"{self.contact}_force":
            del p["name"]
        p["target"] = self._target.tolist() if self.m > 1 else float(self._target[0])
        if self._directions is not None:
            p["directions"] = self._directions.T.tolist()
        for key, default in (("kp", 0.0), ("ki", 0.0), ("integral_limit", 50.0), ("max_force", 1000.0),
                             ("ramp", 0.0), ("source", "simulator"), ("observer_gain", 100.0),
                             ("tangential", "free"), ("motion", None)):
            if getattr(self, key) != default:
                p[key] = getattr(self, key)
        return p
