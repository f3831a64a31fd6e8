"""The torque plan's tables (:mod:`wbc.tasks.torque_stack`): an array's address as its kernel reads
it, and a task's gains copied into the constant table when they are replaced."""

from __future__ import annotations

import numpy as np

__all__ = ["Gains", "address"]


def address(x, order: str = "C") -> int:
    """The data address of x, a float64 array laid out as the kernel reads it; ValueError else.

    Args:
        x: the array.
        order: "C": row-major or a contiguous vector; "F": a column-major matrix, pinocchio's.
    """
    ok = isinstance(x, np.ndarray) and x.dtype == np.float64
    ok = ok and (x.flags.f_contiguous if order == "F" else x.flags.c_contiguous)
    if not ok:
        raise ValueError("an array is not laid out as the plan's kernel reads it")
    return x.__array_interface__["data"][0]


class Gains:
    """A task's K_p, K_d (``gain_vectors(dim)``) copied into ``fx`` at f and f + ``step`` when the
    task's ``kp`` or ``kd`` object is replaced (this record keeps what it copied).

    Args:
        task: the task (its ``gain_vectors``, ``kp``, ``kd``).
        dim: the number of gains.
        f: K_p's first place in ``fx``.
        step: K_d's offset from K_p.
    """

    __slots__ = ("task", "dim", "f", "step", "kp", "kd")

    def __init__(self, task, dim: int, f: int, step: int) -> None:
        self.task, self.dim, self.f, self.step, self.kp, self.kd = task, dim, f, step, None, None

    def copy(self, fx: np.ndarray) -> None:
        """K_p, K_d of the task now into ``fx``, and the objects they came from kept.

        Args:
            fx: the plan's constant table.
        """
        t = self.task
        kp, kd = t.gain_vectors(self.dim)
        f, d = self.f, self.dim
        fx[f:f + d] = kp
        fx[f + self.step:f + self.step + d] = kd
        self.kp, self.kd = t.kp, t.kd
