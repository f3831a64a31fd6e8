"""Closed-form responses the interaction tests compare simulations against."""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm


def msd_response(Lam, D, K, h, t):
    """x(t) of Λ ẍ + D ẋ + K x = h (h constant from t = 0, x(0) = ẋ(0) = 0); Λ, D, K n × n."""
    n = len(h)
    Li = np.linalg.inv(Lam)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Li @ K, -Li @ D]])
    z_ss = np.concatenate([np.linalg.solve(K, h), np.zeros(n)])
    return np.array([(z_ss + expm(A * s) @ (-z_ss))[:n] for s in t])
