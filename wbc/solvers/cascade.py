"""The lexicographic cascade both priority solvers share.

The solution is kept as x = x̂ + Z z, with x̂ the particular solution so far and Z
an orthonormal basis of the directions that no higher level constrains (Z = I at
the start). A level with rows A x = b is solved in that subspace:

    z* = (A Z)^†_λ (b − A x̂),  x̂ ← x̂ + Z z*,  Z ← Z · null(A Z).

With Z Zᵀ = N_{k−1} this is exactly the recursive projection of (5.25):
J̄_k = J_k N_{k−1}, b_k = J_k Σ_{i<k} q̈_i, N_k = N_{k−1} − J̄_k^† J̄_k, written with
a basis instead of an n × n projector (same result, fewer flops, and the rank and
smallest singular value of J̄_k are those of A Z, which diagnostics report).

Damping (only near singularities, Nakamura/Chiaverini variable damping, applied to each
singular direction of A Z by its own singular value σ_i, Chiaverini's selective form):
    λ_i² = 0                                 if σ_i ≥ ε,
    λ_i² = (1 − (σ_i/ε)²) λ_max²             otherwise,
and the step uses σ_i/(σ_i² + λ_i²) in place of 1/σ_i. A level whose σ_min ≥ ε is solved
exactly, as without damping. Rank counts σ > ``rank_tol``·max(1, σ_max). The gain of the
damped inverse is bounded (:meth:`Damping.gain_bound`): with λ_max ≥ ε/√2 (the default
λ_max = ε) every direction's gain σ/(σ² + λ²(σ)) ≤ 1/ε, so a level's step
‖z‖ ≤ ‖b − A x̂‖/ε however close to singular it is; with λ_max = ε exactly, the gain is
σ/ε², falling to 0 with σ (the singular direction gets nothing).

One level is one call of a compiled kernel (:func:`wbc.solvers.kernels.factorizations.level_step`):
the products, the factorisation and the new basis without the interpreter in between
(measured on Talos, 5 levels: the cascade's Python and f2py overhead was about half
of its 0.19 ms; see ``benchmarks/optimisation.md``). The solvers go further: their levels
run in one call (:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`,
:func:`~wbc.solvers.kernels.sns_run.projection_prefix`); this class holds the state between
calls and takes the single steps of a level the hierarchical QP hands to its back-end (and
of the tests' Python references).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels.factorizations import AUTO, damping_lambda2, level_step
from .kernels.records import decode, hint_record, hint_route


@dataclass
class Damping:
    """Singularity-robust inverse (module doc): ``threshold`` ε and ``max_damping`` λ_max, in
    the units of the level's projected Jacobian J̄ = A Z (m per rad for a position row over
    the joints, unitless for an orientation row): 0.01 both by default, i.e. a direction
    is damped once it takes more than 100 rad/s² per m/s² asked, and no direction is ever
    given more (:meth:`gain_bound`); ``rank_tol`` the relative rank tolerance (unitless).

    Args:
        threshold: ε, the singular value below which a direction is damped (units of J̄; ≥ 0,
            0: no damping).
        max_damping: λ_max, the damping at σ = 0 (units of J̄; ≥ 0).
        rank_tol: singular values below ``rank_tol``·max(1, σ_max) count as zero.
    """

    threshold: float = 1e-2
    max_damping: float = 1e-2
    rank_tol: float = 1e-9

    def lambda2(self, smin: float) -> float:
        """λ² for a singular value ``smin`` (the rule of the module docstring)."""
        return damping_lambda2(smin, self.threshold, self.max_damping)

    def gain_bound(self) -> float:
        """max over σ > 0 of the damped gain σ/(σ² + λ²(σ)) (units of 1/J̄): 1/ε when
        λ_max ≥ ε/√2, else 1/(2 λ_max √(1 − λ_max²/ε²)) (the maximum at
        σ* = λ_max/√(1 − λ_max²/ε²) < ε); ∞ without damping. A level's step is at most
        this times its residual ‖b − A x̂‖."""
        eps, lam = self.threshold, self.max_damping
        if eps <= 0.0 or lam <= 0.0:
            return float("inf")
        if lam * lam >= 0.5 * eps * eps:
            return 1.0 / eps
        return 1.0 / (2.0 * lam * (1.0 - (lam / eps) ** 2) ** 0.5)


NO_DAMPING = Damping(threshold=0.0, max_damping=0.0)


class Step:
    """A tentative least-squares step of one level (committed or discarded).

    ``z`` the step in the free directions, ``Z_next`` the basis left for lower levels,
    ``rank``, ``sigma_min``, ``sigma_max`` and ``damping`` (λ²) of AZ, ``x_next`` = x̂ + Z z;
    ``R`` a triangular factor with the singular values of AZ when the route did not
    compute them (see :func:`singular_values`); ``ok`` False when a forced route refused
    the level (:meth:`Cascade.route_step`); ``route`` the factorisation that gave it (a
    route of :mod:`~wbc.solvers.kernels.factorizations`). ``AZ`` and the residual ``r`` = b − A x̂
    are worked out on first access (only a QP needs them)."""

    __slots__ = ("z", "Z_next", "rank", "sigma_min", "sigma_max", "damping", "R", "x_next", "ok", "route",
                 "_A", "_b", "_x", "_Z", "_AZ", "_r")

    def __init__(self, z, Z_next, factor: tuple, level: tuple, R=None, x_next=None, ok=True, route=0) -> None:
        """``factor`` = (rank, σ_min, σ_max, λ²) of AZ; ``level`` = (A, b, x̂, Z) the step was
        taken on (``Z`` None while the basis is the identity)."""
        self.z, self.Z_next = z, Z_next
        self.rank, self.sigma_min, self.sigma_max, self.damping = factor
        self.R, self.x_next, self.ok, self.route = R, x_next, ok, route
        self._A, self._b, self._x, self._Z = level
        self._AZ = self._r = None

    @classmethod
    def unpacked(cls, packed: np.ndarray, Z_next, factor: tuple, level: tuple, dof: int, ok: bool = True,
                 route: int = 0) -> Step:
        """The step from :func:`~wbc.solvers.kernels.factorizations.level_step`'s ``packed`` array
        (z over ``dof`` free directions, x̂ + Z z, then R row by row if any); ``factor`` and
        ``level`` as in the constructor."""
        n = len(level[2])
        R = None
        if len(packed) > dof + n:
            mr = round((len(packed) - dof - n) ** 0.5)
            R = packed[dof + n:].reshape(mr, mr)
        return cls(packed[:dof], Z_next, factor, level, R, packed[dof:dof + n], ok, route)

    @property
    def AZ(self) -> np.ndarray:
        AZ = self._AZ
        if AZ is None:
            AZ = self._AZ = self._A if self._Z is None else self._A @ self._Z
        return AZ

    @property
    def r(self) -> np.ndarray:
        r = self._r
        if r is None:
            r = self._r = self._b - self._A @ self._x
        return r


class Cascade:
    """x = x̂ + Z z over R^n, levels applied one after the other (see module doc).

    Hot path: Z starts as the identity and is not multiplied while it is one. A level
    is factorised by the cheapest route its shape and conditioning allow, each fast
    route accepted only when it can prove what the SVD would decide
    (:mod:`~wbc.solvers.kernels.factorizations`): wide and of full rank, a Householder QR of
    (AZ)ᵀ; tall and well conditioned, the Cholesky factor of the Gram matrix;
    rank deficient with a clear rank, a complete orthogonal decomposition; otherwise
    (near a singularity, damped) the SVD. ``hints`` (a
    :func:`~wbc.solvers.kernels.records.hint_table` kept by the solver across cycles)
    remembers the route a level needed last time, so it goes straight there; each hint
    is retried every ``HINT_RETRY`` cycles."""

    def __init__(self, n: int, hints: np.ndarray | None = None) -> None:
        self.n = n
        self.x = np.zeros(n)
        self.Z = _eye(n)
        self._identity = True
        self._hints = hints
        self._calls = 0

    def kernel_basis(self) -> tuple[np.ndarray, bool]:
        """(Z, is the identity) as the compiled kernels take them (an empty Z while it is
        the identity)."""
        return (_NO_BASIS, True) if self._identity else (self.Z, False)

    @property
    def calls(self) -> int:
        """Least-squares steps taken so far (the index of the next one in the route hints)."""
        return self._calls

    def adopt(self, x: np.ndarray, Z: np.ndarray, identity: bool, calls: int) -> None:
        """Take over the state a compiled run left (:func:`adopt_run`): x̂, the basis Z
        (unless still the identity) and the count of steps."""
        self.x = x
        if not identity:
            self.Z = Z
            self._identity = False
        self._calls = calls

    @property
    def dof(self) -> int:
        """Directions still free for lower levels."""
        return self.Z.shape[1]

    def ls_step(self, A: np.ndarray, b: np.ndarray, damping: Damping) -> Step:
        """Least-squares step of ``A x = b`` inside the current null space (not applied)."""
        m, r_dim = A.shape[0], self.Z.shape[1]
        if m == 0 or r_dim == 0:
            return Step(np.zeros(r_dim), self.Z, (0, np.inf, 0.0, 0.0), (A, b, self.x, None if self._identity else self.Z),
                        x_next=self.x)
        call = self._calls
        self._calls += 1
        hints = self._hints
        if hints is None:
            return self._kernel(A, b, damping, AUTO)
        path = hint_route(hints, call, m, r_dim)
        step = self._kernel(A, b, damping, path)
        hint_record(hints, call, m, r_dim, path, step.route)
        return step

    def _kernel(self, A: np.ndarray, b: np.ndarray, damping: Damping, path: int, strict: bool = False) -> Step:
        A = np.ascontiguousarray(A, dtype=float)
        b = np.ascontiguousarray(b, dtype=float)
        identity = self._identity
        ok, route, rank, smin, smax, lam2, packed, Z_next = level_step(
            A, b, self.x, _NO_BASIS if identity else self.Z, identity, path, strict, damping.rank_tol,
            damping.threshold, damping.max_damping, GRAM_MIN_RATIO)
        return Step.unpacked(packed, Z_next, (rank, smin, smax, lam2), (A, b, self.x, None if identity else self.Z),
                             self.n if identity else self.Z.shape[1], ok, route)

    def route_step(self, A: np.ndarray, b: np.ndarray, damping: Damping, route: int) -> Step | None:
        """The step by one route of :mod:`~wbc.solvers.kernels.factorizations` only (``SVD``, ``QR``,
        ``GRAM``, ``COD``), or None if that route refuses the level: what the tests
        compare the routes with."""
        step = self._kernel(A, b, damping, route, strict=True)
        return step if step.ok else None

    def commit(self, step: Step, z: np.ndarray | None = None) -> None:
        """Apply a step (or another z of the same level, e.g. a QP's) and shrink Z."""
        self.x = step.x_next if z is None and step.x_next is not None else self.x + self.Z @ (step.z if z is None else z)
        if step.Z_next is not self.Z:
            self._identity = False
        self.Z = step.Z_next

    def candidate(self, step: Step) -> np.ndarray:
        return step.x_next if step.x_next is not None else self.x + self.Z @ step.z


_EYE: dict[int, np.ndarray] = {}
#: stands for Z while Z is the identity (the kernel then skips the products with it)
_NO_BASIS = np.zeros((0, 0))


def _eye(n: int) -> np.ndarray:
    """A read-only identity of size n, built once."""
    e = _EYE.get(n)
    if e is None:
        e = np.eye(n)
        e.flags.writeable = False
        _EYE[n] = e
    return e


#: smallest proven σ_min²/σ_max² for the Gram (Cholesky) path (κ(AZ) ≤ 1e4)
GRAM_MIN_RATIO = 1e-8


def adopt_run(levels: list, cas: Cascade, infos: list, start: int, run: tuple) -> tuple:
    """Take over what a compiled run from level ``start`` did
    (:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix` or
    :func:`~wbc.solvers.kernels.sns_run.projection_prefix`; ``run`` its output, (stop, x, Z,
    identity, ints, floats, packed, Z_next)): a LevelInfo per level it solved
    appended to ``infos``, its point and basis into ``cas``. Returns (the first level
    left, the step the kernel took there or None, the QPs it solved by certificate)."""
    stop, x, Z, identity, ints, floats, packed, Z_next = run
    decoded, at, calls, qps = decode(ints, floats, levels, start, stop)
    infos += decoded
    step = None
    if len(packed):
        assert at is not None, "a run that stopped inside a level decodes that level"
        step = Step.unpacked(packed, Z_next, (at.rank, at.sigma_min, at.sigma_max, at.lambda2),
                             (levels[stop].A, levels[stop].b, x, None if identity else Z), at.dof, True, at.route)
    cas.adopt(x, Z, identity, calls)
    return stop, step, qps
