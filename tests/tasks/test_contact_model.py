"""The contact wrench cone is exactly the set of resultants of corner forces inside
the friction pyramid (the closed form of Caron et al., checked against generators)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls

from wbc.tasks import friction_pyramid, wrench_cone


def _generators(mu, X, Y):
    G = []
    for px in (-X, X):
        for py in (-Y, Y):
            for fx, fy in ((mu, mu), (-mu, mu), (mu, -mu), (-mu, -mu)):
                f = np.array([fx, fy, 1.0])
                G.append(np.r_[f, np.cross([px, py, 0.0], f)])
    return np.array(G).T


@pytest.mark.parametrize("mu,X,Y", [(0.7, 0.1, 0.065), (0.3, 0.12, 0.05), (1.0, 0.05, 0.05)])
def test_wrench_cone_equals_span_of_corner_pyramids(mu, X, Y, rng):
    U = wrench_cone(mu, X, Y)
    G = _generators(mu, X, Y)
    assert np.all(U @ G <= 1e-12)            # every generator satisfies every face
    inside = 0
    for _ in range(2000):
        w = rng.standard_normal(6) * np.array([1, 1, 1, 0.1, 0.1, 0.1])
        w[2] = 2 * abs(w[2])
        _, res = nnls(G, w)
        in_span = res < 1e-9 * np.linalg.norm(w)
        inside += in_span
        assert in_span == bool(np.all(U @ w <= 1e-12))
    assert 100 < inside < 1900                # both sides of the boundary were sampled


def test_friction_pyramid_point_contact():
    P = friction_pyramid(0.5)
    assert np.all(P @ np.array([0.4, -0.4, 1.0]) <= 0)
    assert np.any(P @ np.array([0.6, 0.0, 1.0]) > 0)
    assert np.any(P @ np.array([0.0, 0.0, -1.0]) > 0)
