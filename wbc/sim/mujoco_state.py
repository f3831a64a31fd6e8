"""MuJoCo's state in pinocchio's coordinates and the torque command, the per-step parts in
compiled calls (:class:`~wbc.sim.mujoco_sim.MujocoSimulator`, around every step).

:func:`q_of_qpos` (:meth:`~wbc.sim.mujoco_sim.MujocoSimulator.q_from_qpos`). A free-flyer root:
q[0:3] = qpos[a:a+3] (m), q[3:7] = (x, y, z, w) = (qpos[a+4], qpos[a+5], qpos[a+6], qpos[a+3]) / s,
with s = ‖qpos[a+3:a+7]‖ given (numpy's ``dot`` and ``math.sqrt``, as the former
``quat / math.sqrt(quat.dot(quat))``: each entry divided by the same s, so the same bits); every
1-coordinate joint q[qi[k]] = qpos[qm[k]]. A planar root and continuous joints (cos, sin of an
angle) are the caller's.

:func:`read_state` (the step's read-out, a free-flyer or fixed root): q as above and
v = T(q)ᵀ qvel (:meth:`~wbc.sim.mujoco_sim.MujocoSimulator.v_from_qvel`) in one call, with the
former arithmetic written out:

- s² = ((w² + x²) + y²) + z² in qpos's order (OpenBLAS's ``ddot`` of 4 entries: its scalar
  tail, no FMA);
- R from the unit quaternion q[3:7] normalized again, as ``pin.Quaternion(...).normalized().matrix()``
  (Eigen: ‖·‖² = (x² + z²) + (y² + w²) in SSE pairs, each coefficient divided by its square root,
  then ``toRotationMatrix``'s t = 2x, ... formulas);
- v_lin,i = fma(R₂ᵢ, q̇₂, R₀ᵢ q̇₀) + R₁ᵢ q̇₁ (+ 0.0): OpenBLAS's ``dgemv_n`` Haswell kernel on
  ``T.T @ qvel`` (columns in fours: two accumulators, FMA, summed), which on every other row
  adds a single 1 × q̇ⱼ to zeros (the + 0.0 turns a −0.0 to +0.0 as it does).

The BLAS kernel depends on the host: :meth:`~wbc.sim.mujoco_sim.MujocoSimulator` checks
:func:`read_state` against its general path on random states once, and uses the general path
when they differ; a non-finite qvel (the product then NaN everywhere) returns False and the
caller takes the general path too.

:func:`command` (:meth:`~wbc.sim.mujoco_sim.MujocoSimulator.step`): the motors' torques
written to ``ctrl``, the saturation test and the zeroed ``xfrc_applied``.
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np
import pinocchio as pin
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


@intrinsic
def fma(typingctx, a, b, c):
    """a × b + c rounded once (LLVM's ``llvm.fma.f64``; float64 arguments)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)

    return sig, codegen


@nb.njit(cache=True)
def q_of_qpos(qpos, a, s, free_flyer, qi, qm, q):
    """Write q (nq) from MuJoCo's qpos (module docstring): the free-flyer root at qpos[a:a+7]
    when ``free_flyer`` (its quaternion's norm ``s``), and the 1-coordinate joints ``qi`` ←
    ``qm``."""
    if free_flyer:
        q[0], q[1], q[2] = qpos[a], qpos[a + 1], qpos[a + 2]
        q[3], q[4], q[5], q[6] = qpos[a + 4] / s, qpos[a + 5] / s, qpos[a + 6] / s, qpos[a + 3] / s
    for k in range(qi.shape[0]):
        q[qi[k]] = qpos[qm[k]]


@nb.njit(cache=True)
def read_state(qpos, qvel, roots, qi, qm, vi, vm, q, v):
    """Write q (nq) and v (nv) of MuJoCo's qpos and qvel (module docstring). ``roots``: (root's
    qpos address, its qvel address, 1 for a free flyer, 0 for a fixed root); ``qi`` ← ``qm``:
    the 1-coordinate joints' q and qpos indices, ``vi`` ← ``vm``: every joint's v and qvel
    indices. Returns False when qvel has a non-finite entry (q, v then not to be used)."""
    for k in range(qvel.shape[0]):
        if not np.isfinite(qvel[k]):
            return False
    aq, av = roots[0], roots[1]
    if roots[2]:
        w, x, y, z = qpos[aq + 3], qpos[aq + 4], qpos[aq + 5], qpos[aq + 6]
        s = np.sqrt(((w * w + x * x) + y * y) + z * z)
        q[0], q[1], q[2] = qpos[aq], qpos[aq + 1], qpos[aq + 2]
        X, Y, Z, W = x / s, y / s, z / s, w / s
        q[3], q[4], q[5], q[6] = X, Y, Z, W
        n2 = (X * X + Z * Z) + (Y * Y + W * W)
        if n2 > 0.0:
            n = np.sqrt(n2)
            X, Y, Z, W = X / n, Y / n, Z / n, W / n
        tx, ty, tz = 2.0 * X, 2.0 * Y, 2.0 * Z
        twx, twy, twz = tx * W, ty * W, tz * W
        txx, txy, txz = tx * X, ty * X, tz * X
        tyy, tyz, tzz = ty * Y, tz * Y, tz * Z
        p0, p1, p2 = qvel[av], qvel[av + 1], qvel[av + 2]
        v[0] = (fma(txz - twy, p2, (1.0 - (tyy + tzz)) * p0) + (txy + twz) * p1) + 0.0
        v[1] = (fma(tyz + twx, p2, (txy - twz) * p0) + (1.0 - (txx + tzz)) * p1) + 0.0
        v[2] = (fma(1.0 - (txx + tyy), p2, (txz + twy) * p0) + (tyz - twx) * p1) + 0.0
        v[3], v[4], v[5] = qvel[av + 3] + 0.0, qvel[av + 4] + 0.0, qvel[av + 5] + 0.0
    for k in range(qi.shape[0]):
        q[qi[k]] = qpos[qm[k]]
    for k in range(vi.shape[0]):
        v[vi[k]] = qvel[vm[k]] + 0.0
    return True


@nb.njit(cache=True)
def command(tau, full, act, limits, ctrl, xfrc):
    """The motors' torques of ``tau`` (``full``: nv, then its entries ``act``; else na, as given) written to
    ``ctrl`` (na) when all are finite, ``xfrc`` (MuJoCo's ``xfrc_applied``) zeroed. Returns -1
    when one is not finite (nothing written), else 1 when one exceeds its ``limits`` (na, N·m
    or N) in magnitude, else 0."""
    n = ctrl.shape[0]
    for k in range(n):
        t = tau[act[k]] if full else tau[k]
        if not np.isfinite(t):
            return -1
    saturated = 0
    for k in range(n):
        t = tau[act[k]] if full else tau[k]
        ctrl[k] = t
        if abs(t) > limits[k]:
            saturated = 1
    xfrc[:] = 0.0
    return saturated


class StateReader:
    """:func:`read_state` with its constant arguments held, continuous joints (cos, sin of an
    angle) written after it. ``roots``, ``qi``, ``qm``, ``vi``, ``vm``: :func:`read_state`'s;
    ``cont``: per continuous joint (its q index, its qpos address); ``nq``, ``nv``: pinocchio's sizes."""

    def __init__(self, roots: np.ndarray, joints: tuple, cont: list, nq: int, nv: int) -> None:
        """Args:
            roots: (root's qpos address, its qvel address, 1 for a free flyer, 0 fixed).
            joints: (qi, qm, vi, vm), :func:`read_state`'s index arrays.
            cont: per continuous joint (its q index, its qpos address).
            nq: pinocchio's configuration size.
            nv: pinocchio's velocity size.
        """
        self.args = (roots, *joints)
        self.cont, self.nq, self.nv = cont, nq, nv

    def read(self, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(q, v) of MuJoCo's qpos and qvel (new arrays), or None at a non-finite qvel."""
        q, v = np.empty(self.nq), np.empty(self.nv)
        roots, qi, qm, vi, vm = self.args
        if not read_state(qpos, qvel, roots, qi, qm, vi, vm, q, v):
            return None
        for iq, im in self.cont:
            q[iq], q[iq + 1] = math.cos(qpos[im]), math.sin(qpos[im])
        return q, v

    def holds(self, general, nq_mj: int, nv_mj: int, n: int = 64) -> bool:
        """Whether :meth:`read` gives ``general(qpos, qvel)``'s bits (the simulator's general
        path, (q, v)) on ``n`` random MuJoCo states (qpos of size ``nq_mj``, qvel ``nv_mj``; the
        velocities over seven decades): :func:`read_state` writes the products out as this
        host's BLAS computes them."""
        rng = np.random.default_rng(0)
        for k in range(n):
            qpos, qvel = rng.normal(size=nq_mj), rng.normal(size=nv_mj) * 10.0 ** (k % 7 - 3)
            got, want = self.read(qpos, qvel), general(qpos, qvel)
            if got is None or any(a.tobytes() != b.tobytes() for a, b in zip(got, want, strict=True)):
                return False
        return True


class Coordinates:
    """pinocchio's (q, v) <-> MuJoCo's (qpos, qvel) of a :class:`~wbc.sim.mujoco_sim.MujocoSimulator`
    (conventions in its module docstring), on its attributes: ``root``, ``model`` (pinocchio),
    ``mj_model``, the root's qpos and qvel addresses ``_root_q``, ``_root_v`` and dofs
    ``_n_root``, the joints' indices ``_qi`` ← ``_qm`` (q ← qpos), ``_vi`` ← ``_vm`` (v ← qvel),
    the continuous joints ``_cont`` ((q index, qpos address)), and the held maps ``_T0``, ``_T``."""

    root: str
    model: pin.Model
    mj_model: Any
    _root_q: int
    _root_v: int
    _n_root: int
    _qi: np.ndarray
    _qm: np.ndarray
    _vi: np.ndarray
    _vm: np.ndarray
    _cont: list
    _T0: np.ndarray | None
    _T: np.ndarray | None

    def _root_rotation(self, q: np.ndarray) -> np.ndarray:
        if self.root == "free_flyer":
            return pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().matrix()
        c, s = np.array([q[2], q[3]]) / math.hypot(q[2], q[3])
        return np.array([[c, -s], [s, c]])

    def qpos_from_q(self, q: np.ndarray) -> np.ndarray:
        """MuJoCo's qpos of the pinocchio configuration q."""
        qpos, a = np.zeros(self.mj_model.nq), self._root_q
        if self.root == "free_flyer":
            qpos[a: a + 3] = q[:3]
            qpos[a + 3: a + 7] = np.array([q[6], q[3], q[4], q[5]]) / np.linalg.norm(q[3:7])
        elif self.root == "planar":
            qpos[a: a + 3] = q[0], q[1], math.atan2(q[3], q[2])
        qpos[self._qm] = q[self._qi]
        for iq, im in self._cont:
            qpos[im] = math.atan2(q[iq + 1], q[iq])
        return qpos

    def q_from_qpos(self, qpos: np.ndarray) -> np.ndarray:
        """pinocchio's configuration of a MuJoCo qpos."""
        q, a = np.zeros(self.model.nq), self._root_q
        free = self.root == "free_flyer"
        if free:
            quat = qpos[a + 3: a + 7]
            s = math.sqrt(quat.dot(quat))        # np.linalg.norm's arithmetic, without its checks
        else:
            s = 1.0
            if self.root == "planar":
                q[:4] = qpos[a], qpos[a + 1], math.cos(qpos[a + 2]), math.sin(qpos[a + 2])
        q_of_qpos(qpos, a, s, free, self._qi, self._qm, q)     # the free-flyer root and the 1-dof joints
        for iq, im in self._cont:
            q[iq], q[iq + 1] = math.cos(qpos[im]), math.sin(qpos[im])
        return q

    def velocity_map(self, q: np.ndarray) -> np.ndarray:
        """T(q) (nv × nv, orthogonal): qvel = T v."""
        T0 = self._T0
        if T0 is None:      # the part that does not depend on q, built once
            T0, a, n = np.zeros((self.mj_model.nv, self.model.nv)), self._root_v, self._n_root
            if n:
                T0[a: a + n, :n] = np.eye(n)
            T0[self._vm, self._vi] = 1.0
            self._T0 = T0
        T = T0.copy()
        self._root_block(T, q)
        return T

    def _root_block(self, T: np.ndarray, q: np.ndarray) -> None:
        """T's root block (its only part that depends on q) written for q."""
        if self._n_root:
            a, k = self._root_v, (3 if self.root == "free_flyer" else 2)
            T[a: a + k, :k] = self._root_rotation(q)

    def velocity_map_rate(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Ṫ v (MuJoCo's nv, m/s² and rad/s²): q̈_mj = T v̇ + Ṫ v."""
        out, a = np.zeros(self.mj_model.nv), self._root_v
        if self.root == "free_flyer":
            out[a: a + 3] = self._root_rotation(q) @ np.cross(v[3:6], v[:3])
        elif self.root == "planar":
            out[a: a + 2] = v[2] * (self._root_rotation(q) @ np.array([-v[1], v[0]]))
        return out

    def qvel_from_v(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """MuJoCo's qvel of the pinocchio velocity v at q."""
        return self.velocity_map(q) @ v

    def v_from_qvel(self, q: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """pinocchio's velocity of a MuJoCo qvel at q (Tᵀ qvel, T(q) in a matrix held for it: its
        constant part written once, its root block at each call)."""
        T = self._T
        if T is None:
            T = self._T = self.velocity_map(q)
        else:
            self._root_block(T, q)
        return T.T @ qvel

    def _general_state(self, qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = self.q_from_qpos(qpos)
        return q, self.v_from_qvel(q, qvel)
