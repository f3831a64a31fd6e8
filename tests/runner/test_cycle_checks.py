"""The closed loop's per-cycle pieces outside the controller's solve (issue #26), made cheaper
without changing a value: the fall check in one compiled pass, the divergence check on a
simulator's arrays without conversions, the sinusoid reference on Python floats, and the
simulator's free-flyer rotation vector from the compiled free-motion step. Each against the
former code, bit for bit or decision for decision."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.controller.faults import diverged
from wbc.runner.metrics import FALL_HEIGHT_FRACTION, FALL_TILT, fallen
from wbc.sim import contact_rows as cr
from wbc.trajectories.profiles import Sinusoid, smoothstep


def _former_fallen(q: np.ndarray, base_z0: float) -> bool:
    x, y = float(q[3]), float(q[4])
    tilt = math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y))))
    with np.errstate(over="ignore"):
        return bool(q[2] < FALL_HEIGHT_FRACTION * base_z0 or tilt > FALL_TILT
                    or not (math.isfinite(q.dot(q)) or np.all(np.isfinite(q))))


def test_fallen_decides_as_before():
    rng = np.random.default_rng(11)
    z0 = 1.02
    cases = []
    for _ in range(3000):
        q = rng.normal(size=39)
        q[2] = rng.uniform(0.3, 1.2)
        quat = rng.normal(size=4) * rng.choice([1.0, 1e-3])
        quat[3] += rng.choice([0.0, 5.0])                 # mostly upright, some turned over
        q[3:7] = quat / np.linalg.norm(quat)
        cases.append(q)
    for k, bad in enumerate((np.nan, np.inf, -np.inf, 1e200)):
        for i in (0, 2, 3, 20, 38):
            q = cases[k].copy()
            q[i] = bad
            cases.append(q)
    q = cases[0].copy()
    q[2] = FALL_HEIGHT_FRACTION * z0                  # at the threshold: not below it
    cases.append(q)
    seen = set()
    for q in cases:
        want = _former_fallen(q, z0)
        assert fallen(q, z0) is want, q
        seen.add(want)
    assert seen == {True, False}


def test_diverged_takes_arrays_and_lists():
    q, v = np.zeros(7), np.zeros(6)
    assert diverged(q, v) == "" and diverged(q.tolist(), v.tolist()) == ""
    v[3] = np.nan
    assert "not finite" in diverged(q, v) and "not finite" in diverged(q.tolist(), v.tolist())
    q2 = np.zeros((7, 1))
    q2[4, 0] = 1e9
    assert "coordinate" in diverged(q2, np.zeros(6))
    assert "coordinate" in diverged(np.zeros(7, dtype=np.float32) + 1e9, np.zeros(6))


def _former_sample(traj: Sinusoid, t: float):
    w = 2 * np.pi * traj.frequency
    if traj.ramp > 0 and t < traj.ramp:
        s, ds, dds = smoothstep(t / traj.ramp)
        ds, dds = (ds / traj.ramp, dds / traj.ramp / traj.ramp) if s > 0.0 else (0.0, 0.0)
    else:
        s, ds, dds = 1.0, 0.0, 0.0
    sn, cs = np.sin(w * t + traj.phase), np.cos(w * t + traj.phase)
    x = s * sn
    dx = ds * sn + s * w * cs
    ddx = dds * sn + 2 * ds * w * cs - s * w * w * sn
    return traj.amplitude * x, traj.amplitude * dx, traj.amplitude * ddx


@pytest.mark.parametrize("phase", [0.0, 1.3, np.array([0.0, np.pi / 2, 0.4])])
@pytest.mark.parametrize("ramp", [0.0, 1.0])
def test_sinusoid_samples_bit_for_bit(phase, ramp):
    rng = np.random.default_rng(2)
    traj = Sinusoid(np.array([0.01, 0.05, -0.03]), 0.7, phase, ramp)
    for t in np.r_[0.0, rng.uniform(0.0, 30.0, 2000), np.arange(0.0, 2.0, 0.001)]:
        got, want = traj.sample(float(t)), _former_sample(traj, float(t))
        for a, b in zip(got, want, strict=True):
            assert a.dtype == np.float64 and np.array_equal(a, b), t


def test_free_velocity_rotation_vector_is_numpys():
    rng = np.random.default_rng(4)
    for _ in range(2000):
        v = rng.normal(size=12) * rng.choice([1e-3, 1.0, 30.0])
        a = rng.normal(size=12)
        h = rng.choice([1e-3, 5e-4, 1.0 / 3000.0])
        v_free, u, w = cr.free_velocity(v, a, h, True)
        assert np.array_equal(w, -v[3:6] * h)
        assert np.array_equal(v_free, v + h * a)
    v_free, u, w = cr.free_velocity(v, a, h, False)
    assert u.size == 0 and w.size == 0
