"""The CoM sinusoid's references as the loop sets them (#26): Python floats, and the sin and cos
a block of cycles at a time; every value the former arrays' bits."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.errors import WbcError
from wbc.tasks.base import TASK_CHANGES
from wbc.tasks.com import CoM
from wbc.trajectories.profiles import BLOCK, Sinusoid, SinusoidCycles


def _bits(values) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.int64)


def _former(traj: Sinusoid, t: float, start):
    """What the loop set before: ``start + x`` of ``sample``'s arrays (``x`` without a start)."""
    x, dx, ddx = traj.sample(t)
    return (x if start is None else start + x), dx, ddx


def _random_sinusoid(rng) -> Sinusoid:
    amp = rng.normal(size=3) * 10.0 ** rng.uniform(-6, 2, size=3)
    amp[rng.random(3) < 0.25] = 0.0
    amp[rng.random(3) < 0.1] = -0.0
    phase = float(rng.choice([0.0, -0.0, rng.uniform(-7, 7)]))
    return Sinusoid(amp, float(10.0 ** rng.uniform(-2, 0.7)), phase, float(rng.choice([0.0, 0.3, 1.0, 2.5])))


def _start(rng):
    return None if rng.random() < 0.3 else rng.normal(size=3) * rng.choice([1e-3, 1.0, 50.0])


def _assert_same(got, want, where) -> None:
    for a, b in zip(got, want, strict=True):
        assert type(a) is list and np.array_equal(_bits(a), _bits(b)), where


def test_reference_values_are_start_plus_sample_bit_for_bit():
    rng = np.random.default_rng(26)
    for _ in range(400):
        traj, start = _random_sinusoid(rng), _start(rng)
        for t in np.r_[0.0, rng.uniform(-1.0, 3.0, 20), rng.uniform(3.0, 600.0, 10)]:
            _assert_same(traj.reference_values(float(t), start), _former(traj, float(t), start), (traj, t))


@pytest.mark.parametrize("traj", [
    Sinusoid(np.array([0.01, 0.05, -0.03]), 0.7, np.array([0.0, np.pi / 2, 0.4]), 1.0),   # a phase per axis
    Sinusoid(np.array([0.2]), 0.3, 0.5, 0.5),                                             # not a 3-vector
    Sinusoid(np.array([1, 0, 2]), 0.5, 0.0, 0.0),                                         # integers
])
def test_reference_values_of_the_other_shapes_are_the_arrays(traj):
    rng = np.random.default_rng(3)
    n = len(traj.amplitude)
    for t in rng.uniform(0.0, 5.0, 200):
        for start in (None, rng.normal(size=n)):
            _assert_same(traj.reference_values(float(t), start), _former(traj, float(t), start), t)


@pytest.mark.parametrize("dt", [1e-3, 1.0 / 3000.0, 2e-3, 0.01])
def test_the_cycles_values_are_each_cycles_own(dt):
    """The block's values against the per-cycle call at the loop's time ``k * dt - t0``, cycles
    in order across several blocks and the ramp's end, then in random order, a start of the
    trajectory later than 0, and the sinusoid's frequency and phase changed mid-run."""
    rng = np.random.default_rng(int(dt * 1e6))
    for case in range(12):
        traj, start = _random_sinusoid(rng), _start(rng)
        t0 = float(rng.choice([0.0, 0.37, 1.234, 5 * dt]))
        k_first = int(round(t0 / dt))
        cycles = SinusoidCycles(traj, dt, t0)
        ks = list(range(k_first, k_first + 2 * BLOCK + int(traj.ramp / dt) + 7))
        ks += [int(k) for k in rng.integers(k_first, k_first + 20 * BLOCK, 300)]
        for j, k in enumerate(ks):
            if case % 3 == 0 and j == len(ks) // 2:
                traj.frequency *= 1.1
                traj.phase += 0.25
            want = traj.reference_values(k * dt - t0, start)
            _assert_same(cycles.values(k, start), want, (case, k))
        assert len(cycles._x) == BLOCK         # the blocks were in use


def test_set_reference_values_sets_what_set_reference_sets():
    rng = np.random.default_rng(5)
    for _ in range(200):
        p, v, a = (list(rng.normal(size=3)) for _ in range(3))
        p = [float(x) for x in p]
        v = [float(x) for x in v]
        a = [float(x) for x in a]
        new, old = CoM(), CoM()
        n0 = TASK_CHANGES[0]
        new.set_reference_values(p, v, a)
        n1 = TASK_CHANGES[0]
        old.set_reference(np.array(p), np.array(v), np.array(a))
        assert TASK_CHANGES[0] - n1 == n1 - n0 > 0
        for got, want in ((new.target, old.target), (new.target_velocity, old.target_velocity),
                          (new.target_acceleration, old.target_acceleration)):
            assert got.dtype == np.float64 and got.shape == (3,) and np.array_equal(_bits(got), _bits(want))


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
@pytest.mark.parametrize("which", [0, 1, 2])
def test_set_reference_values_refuses_what_set_reference_refuses(bad, which):
    values = [[0.1, 0.2, 0.3], [0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]
    values[which][1] = bad
    with pytest.raises(WbcError) as new:
        CoM().set_reference_values(*values)
    with pytest.raises(WbcError) as old:
        CoM().set_reference(*(np.array(x) for x in values))
    assert str(new.value) == str(old.value)
