"""The joint torques of a solution and their limits, compiled: one call per cycle.

τ = S_a (M q̈ + h − J_fᵀ f) (5.26) from x = (q̈, f), clipped to ±τ_max (the controller's
saturation), and the rows' values (residuals) of the same x, in one numba call
(:func:`cycle_outputs`) so that a cycle crosses from Python once for all of them.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.problem.buffer import row_values


@nb.njit(cache=True)
def saturate(tau, actuated, tau_max, tol):
    """Clip τ_i to [−τ_max,i, τ_max,i] in place over the actuated joints; returns (the
    worst |τ_i|/τ_max,i before, how many joints were beyond τ_max,i (1 + tol) + 1e-9).
    Non-finite entries are left (the caller fails the cycle)."""
    worst = 0.0
    n = 0
    for i in actuated:
        lim = tau_max[i]
        t = tau[i]
        a = abs(t)
        if lim > 0.0:
            worst = max(worst, a / lim)
        elif a > 0.0:
            worst = np.inf
        if a > lim:
            if a > lim * (1.0 + tol) + 1e-9:
                n += 1
            tau[i] = lim if t > 0.0 else -lim
    return worst, n


@nb.njit(cache=True)
def joint_torques(M, h, Jf, x, unactuated):
    """(τ = M q̈ + h − J_fᵀ f with zeros on the unactuated rows (5.26), whether x and τ are
    all finite), x = (q̈, f)."""
    nv = M.shape[0]
    tau = np.empty(nv)
    np.dot(M, x[:nv], tau)      # M q̈ by the same product as ``M @ q̈``, in place (no temporary)
    tau += h
    if Jf.shape[0]:
        tau -= Jf.T @ x[nv:]
    for i in unactuated:
        tau[i] = 0.0
    finite = np.all(np.isfinite(x)) and np.all(np.isfinite(tau))
    return tau, finite


@nb.njit(cache=True)
def cycle_outputs(M, h, Jf, x, unactuated, A, b, C, lo, hi, actuated, tau_max, tol):
    """(τ saturated by :func:`saturate`, whether x and τ are finite, the rows' values of
    :func:`~wbc.stack.row_values` (residuals +inf when not finite), the worst |τ_i|/τ_max,i
    before saturation, the joints saturated)."""
    tau, finite = joint_torques(M, h, Jf, x, unactuated)
    values = row_values(A, b, C, lo, hi, x)
    if not finite:
        values[:b.shape[0] + lo.shape[0]] = np.inf
        return tau, finite, values, np.inf, 0
    ratio, n = saturate(tau, actuated, tau_max, tol)
    return tau, finite, values, ratio, n
