"""What the chapter's motion controllers (5.2) share: gains, references, errors.

Every controller of :mod:`wbc.chapter.joint_space` and :mod:`wbc.chapter.task_space`
is a small object called once per control cycle,

    tau = controller(q, v, t)        # q (nq,) rad, v (nv,) rad/s, t s -> tau (nv,) N·m

and the elastic-joint controllers of :mod:`wbc.chapter.elastic_joints` take the
four measured variables of an elastic joint instead of (q, v) (see there).

Gains are positive definite matrices in the chapter; here a gain may be given as
a scalar (k I), a vector (a diagonal) or a full symmetric matrix, and is stored as
an n × n array. A reference is a constant vector, an object with ``sample(t) ->
(x, ẋ, ẍ)`` (the classes of :mod:`wbc.trajectories.position`), or a callable ``t -> (x, ẋ, ẍ)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from wbc.errors import ControllerDefinitionError, TargetError
from wbc.validation.inputs import finite_vector

Vector = np.ndarray
Matrix = np.ndarray
Sample = tuple[np.ndarray, np.ndarray, np.ndarray]


class MotionController(Protocol):
    """What every rigid-body controller of :mod:`wbc.chapter` is: ``(q, v, t) -> τ``."""

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector: ...


def gain_matrix(owner: str, key: str, value, n: int, definite: bool = True) -> Matrix:
    """``value`` (scalar, n-vector or n × n) as a symmetric n × n matrix.

    ``definite=True`` demands positive definiteness (every eigenvalue > 0), else
    positive semidefiniteness (>= 0). Raises :class:`ControllerDefinitionError`
    naming the controller and the gain.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ControllerDefinitionError(f"{owner}: {key} must be numeric, got {value!r}") from exc
    if arr.ndim == 0:
        mat = float(arr) * np.eye(n)
    elif arr.shape == (n,):
        mat = np.diag(arr)
    elif arr.shape == (n, n):
        mat = arr.copy()
    else:
        raise ControllerDefinitionError(
            f"{owner}: {key} must be a number, a vector of {n} or a {n}×{n} matrix, got shape {arr.shape}")
    if not np.all(np.isfinite(mat)):
        raise ControllerDefinitionError(f"{owner}: {key} contains NaN or inf")
    if not np.allclose(mat, mat.T, rtol=1e-10, atol=1e-12):
        raise ControllerDefinitionError(f"{owner}: {key} must be symmetric")
    low = float(np.linalg.eigvalsh(mat).min())
    if (definite and low <= 0.0) or (not definite and low < 0.0):
        what = "positive definite (> 0)" if definite else "positive semidefinite (>= 0)"
        raise ControllerDefinitionError(f"{owner}: {key} must be {what}, got smallest eigenvalue {low:g}")
    return mat


def vector(owner: str, key: str, value, n: int) -> Vector:
    """A finite float vector of exactly ``n`` entries, or a :class:`~wbc.errors.TargetError`."""
    return finite_vector(owner, key, value, n)


class Reference:
    """A reference (x_d, ẋ_d, ẍ_d) of dimension ``n`` at time t (SI units of x per s^k).

    Built from a constant vector (ẋ_d = ẍ_d = 0), an object with ``sample(t)``
    (e.g. :class:`wbc.trajectories.position.Sinusoid`) or a callable ``t -> (x, ẋ, ẍ)``.
    Every sample is checked for shape and finiteness.
    """

    def __init__(self, owner: str, key: str, value, n: int) -> None:
        self.owner, self.key, self.n = owner, key, n
        if hasattr(value, "sample"):
            self._fn: Callable[[float], Sample] | None = value.sample
            self._const = None
        elif callable(value):
            self._fn, self._const = value, None
        else:
            self._fn = None
            x = vector(owner, key, value, n)
            self._const = (x, np.zeros(n), np.zeros(n))

    def __call__(self, t: float) -> Sample:
        if self._const is not None:
            return self._const
        out = self._fn(t)
        if not (isinstance(out, tuple) and len(out) == 3):
            raise TargetError(f"{self.owner}: {self.key}(t) must return (x, xdot, xddot), got {out!r}")
        return tuple(vector(self.owner, f"{self.key}{s}", o, self.n)
                     for s, o in zip(("", " velocity", " acceleration"), out))


def check_state(owner: str, robot, q, v) -> tuple[Vector, Vector]:
    """(q, v) as float vectors of the robot's sizes (nq, nv), or a TargetError."""
    return vector(owner, "q", q, robot.nq), vector(owner, "v", v, robot.nv)
