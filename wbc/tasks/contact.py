"""Rigid unilateral contact with Coulomb friction: a sole on the ground, a hand on a table."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.robot.model import LOCAL, WORLD_ALIGNED, ContactSurface
from wbc.validation.schema import boolean, number, text

from ..errors import TaskDefinitionError
from ..options import Options
from ..problem.rows import ContactData, Layout, Rows, RowSlot
from .base import MotionTask, Watched, eq_rows
from .velocity_frames import frame_motion_rows


def wrench_cone(mu: float, X: float, Y: float) -> np.ndarray:
    """16 × 6 matrix U with U w ≤ 0 ⇔ the wrench w = (f, τ) (N, N·m, at the centre of a
    2X × 2Y rectangle, in its frame, normal +z) is the resultant of corner forces inside
    the linearised friction pyramid |f_x|, |f_y| ≤ μ f_z.

    Rows: friction (4), centre of pressure inside the rectangle |τ_x| ≤ Y f_z,
    |τ_y| ≤ X f_z (4), and the yaw-torque bounds (8) of the closed-form contact
    wrench cone of a rectangular support (Caron, Pham, Nakamura, ICRA 2015).

    Args:
        mu: Coulomb friction coefficient μ (unitless, > 0).
        X: half length of the rectangle along the frame's x (m).
        Y: half width of the rectangle along the frame's y (m).
    """
    U = np.zeros((16, 6))
    U[0:4, 2] = -mu
    U[0, 0], U[1, 0], U[2, 1], U[3, 1] = -1.0, 1.0, -1.0, 1.0
    U[4:6, 2] = -Y
    U[4, 3], U[5, 3] = -1.0, 1.0
    U[6:8, 2] = -X
    U[6, 4], U[7, 4] = -1.0, 1.0
    r = 8
    for sz in (-1.0, 1.0):            # τ_z upper (sz = -1 row: -τ_z ...) and lower bound
        for sx in (-1.0, 1.0):
            for sy in (-1.0, 1.0):
                # sz τ_z ≤ μ(X+Y) f_z − |Y f_x + sz μ τ_x| − |X f_y + sz μ τ_y|, sign-expanded
                U[r] = [sx * Y, sy * X, -(X + Y) * mu, sz * sx * mu, sz * sy * mu, sz]
                r += 1
    return U


def wrench_cone_generators(mu: float, X: float, Y: float) -> np.ndarray:
    """6 × 16 matrix V whose columns span the cone of :func:`wrench_cone`: the wrenches
    at the rectangle's centre of the edges (±μ, ±μ, 1) of the friction pyramid at its
    four corners. Every w = V λ with λ ≥ 0 is a feasible contact wrench and back.

    Args:
        mu: Coulomb friction coefficient μ (unitless, > 0).
        X: half length of the rectangle along the frame's x (m).
        Y: half width of the rectangle along the frame's y (m).
    """
    V = []
    for px in (-X, X):
        for py in (-Y, Y):
            for fx, fy in ((mu, mu), (-mu, mu), (mu, -mu), (-mu, -mu)):
                f = np.array([fx, fy, 1.0])
                V.append(np.concatenate([f, np.cross([px, py, 0.0], f)]))
    return np.array(V).T


def friction_pyramid(mu: float) -> np.ndarray:
    """5 × 3 matrix P with P f ≤ 0 ⇔ |f_x|, |f_y| ≤ μ f_z and f_z ≥ 0 (normal +z).

    Args:
        mu: Coulomb friction coefficient μ (unitless, > 0).
    """
    return np.array([[-1, 0, -mu], [1, 0, -mu], [0, -1, -mu], [0, 1, -mu], [0, 0, -1.0]])


#: default ``cop_margin`` of a sole contact: the fraction of its half sizes kept between the
#: centre of pressure and the sole's edges (see :class:`Contact`)
COP_MARGIN = 0.2


@dataclass(frozen=True)
class ContactOptions(Options):
    """A contact's force model (:class:`Contact`'s ``Args``; each checked by Contact)."""

    mu: float | None = None
    """Coulomb friction coefficient μ of the pyramid (unitless, > 0); None: the robot's surface's"""
    fmin: float = 0.0
    """lower bound of the normal force f_z, N (≥ 0)"""
    bilateral: bool = False
    """True drops the force inequalities (a gripped handle, a welded foot)"""
    cop_margin: float = COP_MARGIN
    """fraction of the sole's half sizes kept between the CoP and its edges (unitless, in [0, 1))"""
    sliding: bool = False
    """the contact may slide along its surface"""


class Contact(MotionTask):
    """A rigid contact of the robot surface ``contact`` (a name under ``contacts:`` in
    the robot YAML) with the environment.

    Equality rows: zero contact acceleration with a PD stabilisation towards the
    placement where the contact was made,
        J_c q̈ = −J̇_c q̇ + K_p e − K_d v_c,
    with J_c the LOCAL 6 × nv Jacobian and e = log₆(ᵒM_c⁻¹ ᵒM_ref) for a surface,
    or the world-aligned 3 × nv linear Jacobian and e = p_ref − p for a point.

    Inequality rows on its force variables (N, N·m, in the contact frame):
    unilateral normal force f_z ≥ ``fmin``, linearised friction pyramid with
    ``mu`` (default: the robot's), and for a surface the centre of pressure inside
    the sole and the yaw-torque bounds (:func:`wrench_cone`). ``bilateral=True``
    drops the inequalities (a gripped handle, a welded foot).

    ``cop_margin`` (dimensionless, [0, 1), default :data:`COP_MARGIN`): the CoP is kept
    inside the sole rectangle shrunk about its centre by that fraction of each half size,
    |p_x| ≤ (1 − m) X and |p_y| ≤ (1 − m) Y, i.e. the wrench cone of the smaller
    rectangle (a subset of the sole's own: every force at its corners is a force inside
    the sole). On Talos (X = 0.1 m, Y = 0.065 m) the default keeps the CoP 2 cm from the
    toe and heel and 1.3 cm from the sides. Why not the edge: a CoP on the edge means the
    sole is about to roll, with no margin left for what the model does not know (soft
    soles and soft contact models, which load the edge before the rectangle's corners;
    encoder and calibration errors of a few mm; the next cycle's disturbance). A fifth
    of the half sizes still leaves 64 % of the sole's area to the CoP. Ignored by point
    contacts.

    ``sliding=True``: the contact may slide along its surface (a hand wiping a table). Its
    equality rows keep only the directions the surface constrains, the normal translation (a
    point: world z; a surface: its LOCAL z and the two tilts x, y), the natural constraint
    J_φ q̇ = 0 of 5.30; the tangential motion is left to a motion task (the hybrid force/motion
    construct, :mod:`wbc.interaction.hybrid_selection`) and the force inequalities stay as they are.

    Args:
        contact: the robot's contact surface, a name under ``contacts:`` in the robot YAML
            (``left_foot``).
        kp: stabilisation gain K_p of the contact's motion (1/s², ≥ 0): a number, or one per
            constrained axis (6 for a surface, 3 for a point); default 10.
        kd: its derivative gain K_d (1/s, ≥ 0), as ``kp``; None (default): critical damping 2√kp.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; None: ``"<contact>_contact"``.
        options: the force model below in one :class:`ContactOptions` (None: its defaults).
        **settings: its fields one by one, over ``options`` (another name is a TypeError):

        mu: Coulomb friction coefficient μ of the pyramid (unitless, > 0); None: the robot's
            (the surface's ``mu``).
        fmin: lower bound of the normal force f_z (N, ≥ 0); default 0 (unilateral).
        bilateral: True drops the force inequalities (a gripped handle, a welded foot); default
            False.
        cop_margin: fraction of the sole's half sizes kept between the CoP and its edges
            (unitless, in [0, 1)); default :data:`COP_MARGIN` (0.2). Ignored by point contacts.
        sliding: True: the contact may slide along its surface (above); default False.
    """

    kind = "contact"
    sliding: bool = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)
    reference: pin.SE3 | None = Watched()  # (base.Watched: its assignments counted in TASK_CHANGES)

    options_record = ContactOptions

    def __init__(self, contact: str, kp: float = 10.0, kd=None, weight: float = 1.0,
                 name: str | None = None, options: ContactOptions | None = None, **settings) -> None:
        text(contact, "contact", what="a contact name (under contacts: in the robot YAML)",
             error=TaskDefinitionError, owner="task 'contact'")
        super().__init__(name or f"{contact}_contact", kp, kd, weight)
        self._za: tuple | None = None      # zero axes of :meth:`_zero_axes`
        self.contact = contact
        owner = f"task '{self.name}'"
        o = ContactOptions.of(options, settings, owner)
        mu, fmin, bilateral, cop_margin, sliding = o.mu, o.fmin, o.bilateral, o.cop_margin, o.sliding
        if mu is not None:
            mu = number(mu, "mu", gt=0, unit="unitless", error=TaskDefinitionError, owner=owner)
        fmin = number(fmin, "fmin", ge=0, unit="N", error=TaskDefinitionError, owner=owner)
        bilateral = boolean(bilateral, "bilateral", error=TaskDefinitionError, owner=owner)
        self.sliding = boolean(sliding, "sliding", error=TaskDefinitionError, owner=owner)
        margin = cop_margin
        if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not 0.0 <= margin < 1.0:
            raise TaskDefinitionError(f"task '{self.name}': cop_margin must be in [0, 1) (a fraction of the "
                                      f"sole's half sizes), got {cop_margin!r}")
        self.cop_margin = float(margin)
        self.mu = mu
        self.fmin = float(fmin)
        self.bilateral = bool(bilateral)
        self.reference = None
        #: upper bound on the normal force (N); ramped by the controller when the
        #: contact is made or released so the torques stay continuous
        self.fmax = np.inf
        self._surface: ContactSurface | None = None
        self._fid = None
        self._ineq: tuple | None = None       # (key, C) of the friction rows
        self._gen: tuple | None = None        # (key, f0, V) of the generators
        self._data: ContactData | None = None  # the last contact_data (an immutable record)
        self._held: tuple = (None, None)  # (reference, its translation) of rows
        self._error = np.zeros(6)

    def bind(self, robot) -> None:
        self.surface(robot)
        self.check_gain_sizes(self.force_dim)

    def _bound(self) -> ContactSurface:
        """The contact surface (the task bound to a robot, :meth:`bind`)."""
        s = self._surface
        if s is None:
            raise TaskDefinitionError(f"task '{self.name}' is not bound to a robot (Controller binds it)")
        return s

    def surface(self, robot) -> ContactSurface:
        if self._surface is None:
            self._surface = robot.contact(self.contact)
            self._fid = robot.frame_id(self._surface.frame)
        return self._surface

    @property
    def force_dim(self) -> int:
        if self._surface is None:
            raise TaskDefinitionError(f"task '{self.name}': not bound to a robot yet")
        return self._surface.force_dim

    def force_jacobian(self, robot) -> np.ndarray:
        """J_c (force_dim × nv): J_cᵀ f is the joint torque the contact force produces."""
        s = self.surface(robot)
        if s.kind == "surface":
            return robot.frame_jacobian(self._fid, LOCAL)
        return robot.frame_jacobian(self._fid, WORLD_ALIGNED)[:3]

    def _errors(self, robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e, v_c, J̇_c q̇) of the rows' docstring."""
        s = self._surface if self._surface is not None else self.surface(robot)
        fid = self._fid
        oMc = robot.frame_placement(fid)
        if self.reference is None:
            self.reference = oMc.copy()
        if s.kind == "surface":
            e = pin.log6(oMc.actInv(self.reference)).vector
            vel = robot.frame_velocity(fid, LOCAL)
            drift = robot.frame_drift(fid, LOCAL, classical=False)
        else:
            e = self.reference.translation - oMc.translation
            vel = robot.frame_velocity(fid, WORLD_ALIGNED)[:3]
            drift = robot.frame_drift(fid, WORLD_ALIGNED)[:3]
        return e, vel, drift

    def error(self, robot) -> np.ndarray:
        """Drift from the contact placement: (m, rad) for a surface, m for a point (a sliding
        contact: along its constrained directions only)."""
        e = self._errors(robot)[0]
        return e[self._zero_axes(len(e))[1]]

    def error_units(self, robot) -> tuple[str, ...]:
        s = self._surface if self._surface is not None else self.surface(robot)
        axes = self._zero_axes(s.force_dim)[1]
        return tuple("m" if s.force_dim == 3 or i < 3 else "rad" for i in axes)

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        s = self._surface if self._surface is not None else self.surface(robot)
        m = s.force_dim
        zero, axes = self._zero_axes(m)
        slot = eq_rows(out, len(axes), layout.nx)
        A, b = slot.A, slot.b
        kp, kd = self.gain_vectors(m)
        ref = self.reference
        if ref is None:
            ref = self.reference = robot.frame_placement(self._fid).copy()
        held = self._held
        if held[0] is not ref:                      # the reference's translation, read once per reference
            held = self._held = (ref, ref.translation)
        frame = robot.frame_arrays(self._fid)
        e = self._error
        if m == 6:
            e[:] = pin.log6(frame.placement.actInv(ref)).vector
        # J_c q̈ = K_p e − K_d v_c − J̇_c q̇, in one compiled call from pinocchio's arrays
        frame_motion_rows(A, b, robot.joint_jacobians, frame.views, held[1], e, axes, zero, kp, kd, zero, m == 6)
        if self.bilateral:
            return Rows(A=A, b=b)
        C = self._friction_rows(layout)
        self.bound_normal_force()
        return Rows(A=A, b=b, C=C, lo=self._lo, hi=self._hi)

    def bound_normal_force(self) -> None:
        """This cycle's f_max (N) into the friction rows' last upper bound, f_z ≤ f_max (``rows``
        does it, and :class:`~wbc.tasks.torque_stack.TorquePlan` in its place)."""
        self._hi[-1] = self.fmax

    def friction_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The friction rows' arrays C, l, u as ``rows`` last gave them (None: not built yet, or
        bilateral): refilled in place while the layout and ``cop_margin`` hold."""
        if self._ineq is None or self.bilateral:
            return None
        return self._ineq[1], self._lo, self._hi

    def _zero_axes(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        got = self._za
        if got is None or len(got[0]) != m or got[2] != self.sliding:
            axes = np.array([2] if m == 3 else [2, 3, 4]) if self.sliding else np.arange(m)
            got = self._za = (np.zeros(m), axes, self.sliding)
        return got[0], got[1]

    def cop_rectangle(self) -> tuple[float, float]:
        """(X, Y) (m): the half sizes of the rectangle the CoP is kept in, the sole's shrunk by
        ``cop_margin``."""
        s = self._bound()
        k = 1.0 - self.cop_margin
        return k * s.half_length, k * s.half_width

    def _friction_rows(self, layout: Layout) -> np.ndarray:
        sl = layout.contact_slices[self.name]
        key = (layout.nx, sl.start, self.cop_margin)
        if self._ineq is None or self._ineq[0] != key:
            s = self._bound()
            mu = s.mu if self.mu is None else self.mu
            U = wrench_cone(mu, *self.cop_rectangle()) if s.kind == "surface" else friction_pyramid(mu)[:4]
            unilateral = np.zeros((2, s.force_dim))
            unilateral[0, 2] = -1.0          # f_z >= fmin
            unilateral[1, 2] = 1.0           # f_z <= fmax
            U = np.vstack([U, unilateral])
            C = np.zeros((U.shape[0], layout.nx))
            C[:, sl] = U
            self._lo = np.full(U.shape[0], -np.inf)
            self._hi = np.zeros(U.shape[0])
            self._hi[-2] = -self.fmin
            self._ineq = (key, C)
        return self._ineq[1]

    def contact_data(self) -> ContactData:
        """This cycle's contact as a solver sees it (:class:`~wbc.problem.rows.ContactData`): the last one
        returned (a named tuple: immutable) while its name, ``mu``, ``fmin``, ``fmax``, ``bilateral`` and
        ``cop_margin`` are the very objects it holds (``is``: a value set anew, even an equal one, makes a new
        record, so a −0.0 for a 0.0 or an int for a float is seen; 0.3 µs against 0.6-0.8 to build one, every
        contact every cycle), else a new one."""
        d = self._data
        if d is not None and d.fmax is self.fmax and d.fmin is self.fmin and d.mu is self.mu \
                and d.cop_margin is self.cop_margin and d.bilateral is self.bilateral and d.name is self.name:
            return d
        d = self._data = ContactData(self.name, self.mu, self.fmin, self.fmax, self.bilateral, self.cop_margin,
                                     self.generators)
        return d

    def generators(self) -> tuple[np.ndarray, np.ndarray]:
        """(f0, V): every admissible force is f0 + V λ with λ ≥ 0 (f0 carries ``fmin``);
        a bilateral contact gets V = [I, −I]. Both live in the contact frame: built once,
        rebuilt only when ``mu``, ``fmin`` or ``bilateral`` change."""
        s = self._bound()
        mu = s.mu if self.mu is None else self.mu
        key = (mu, self.fmin, self.bilateral, s.kind, s.half_length, s.half_width, self.cop_margin)
        if self._gen is not None and self._gen[0] == key:
            return self._gen[1], self._gen[2]
        d = s.force_dim
        f0 = np.zeros(d)
        if self.bilateral:
            V = np.hstack([np.eye(d), -np.eye(d)])
        else:
            f0[2] = self.fmin
            if s.kind == "surface":
                V = wrench_cone_generators(mu, *self.cop_rectangle())
            else:
                V = np.array([[mu, mu, 1.0], [-mu, mu, 1.0], [mu, -mu, 1.0], [-mu, -mu, 1.0]]).T
        f0.flags.writeable = False
        V.flags.writeable = False
        self._gen = (key, f0, V)
        return f0, V

    def normal_force(self, f: np.ndarray) -> float:
        """Normal component (N) of this contact's force vector."""
        return float(f[2])

    def params(self) -> dict:
        p: dict[str, Any] = {"contact": self.contact}
        p.update(super().params())
        if p["name"] == f"{self.contact}_contact":
            del p["name"]
        if self.mu is not None:
            p["mu"] = self.mu
        if self.fmin:
            p["fmin"] = self.fmin
        if self.bilateral:
            p["bilateral"] = True
        if self.cop_margin != COP_MARGIN:
            p["cop_margin"] = self.cop_margin
        if self.sliding:
            p["sliding"] = True
        return p
