"""``talos_hands_cross`` holds its criteria under rounding-level perturbations of the measured velocity.

The closed loop is chaotic at rounding level: the same run with v measured as v (1 + 1e-14 ξ), ξ ~ N(0, 1) drawn
per coordinate and cycle, drifts by up to 15 N·m of torque within seconds, so a change that only changes rounding
(another factorization, another summation order) runs a different trajectory. With the critically damped damper
(``pole_ratio: 1``) such runs relaxed level 0 at the arms' crossing (2.17-2.41 s; 6-33 relaxed cycles a 9 s run,
``benchmarks/collisions.md``): the row of an upper arm sliding past the torso, at rest 10 mm above d_s, asked it to
be pushed away at +2 m/s² against its curvature drift while the shoulder ran at its velocity limit. The barrier's
second pole (:mod:`wbc.tasks.collision_avoidance`, ``pole_ratio: 1.5``, opt-in) asks nothing of a pair that deep
inside its safe set.

The scenario as bundled keeps the damper and takes those rows' drift as ``drift: switching``: the upper arm's
"curvature" was the staircase of its hull features' switches, read by the ±10 ms second difference as −4 to −8 m/s²
(switches already passed included); with ``switching`` a switch that leaves the pair in its safe set is a jump of
ḋ, not an acceleration, and the pieces' curvature is the largest one-sided difference over ±10 ms and ±0.25 ms
(switches on both sides of the ±10 ms window lowered both long ones): the second test (``slow``), no relaxed cycle
on seeds 1-8 where the exact drift relaxes tens.

Each seed's run checks the scenario's criteria over the crossing (the first 2.5 s, own simulator): no relaxed
level, no solver failure, no fall, every monitored pair ≥ d_s − 1 mm on the simulator's true state. Not the whole
run: with ``pole_ratio: 1.5`` the hands' pair ``arm_left_7/arm_right_5`` reaches 2.8 mm at 7.2 s in MuJoCo
(unperturbed), the drift's error at hull feature switches (``benchmarks/collisions.md``).
"""

from __future__ import annotations

import numpy as np
import pytest

from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config

#: the relative size of the perturbation of the measured velocity (unitless): rounding level
EPS = 1e-14


class PerturbedVelocity:
    """The simulator, its measured v multiplied by (1 + EPS ξ) per coordinate (ξ ~ N(0, 1), drawn from ``rng``)."""

    def __init__(self, sim, rng: np.random.Generator) -> None:
        self._sim, self._rng = sim, rng

    def measure(self) -> tuple[np.ndarray, np.ndarray]:
        q, v = self._sim.measure()
        return q, v * (1.0 + EPS * self._rng.normal(size=v.shape))

    def __getattr__(self, name):
        return getattr(self._sim, name)


def _run(seed: int, simulator: str, duration: float | None, pole_ratio: float | None = None,
         drift: str | None = None) -> tuple[dict, float]:
    sc = load_config("talos_hands_cross")
    task = next(t for t in sc.stack if t.kind == "collision_avoidance")
    if pole_ratio is not None:
        task.pole_ratio, task.gamma = pole_ratio, pole_ratio * task.omega
    if drift is not None:           # the loader bound the model with the scenario's drift
        task.drift = drift
        task.model.switch_jump = drift == "switching"
    rng = np.random.default_rng(seed)
    r = ScenarioRun(sc, simulator=simulator, duration=duration, wrap_simulator=lambda s: PerturbedVelocity(s, rng))
    relaxed = 0
    for k in range(r.n):
        if not r.cycle(k):
            break
        relaxed += bool(r.last_sol is not None and r.last_sol.relaxed)
    m = r.metrics()
    assert relaxed == m["relaxed_cycles"]
    return m, task.safety


def _check(m: dict, safety: float) -> None:
    assert not m["fell"] and m["stopped"] is None
    assert m["relaxed_cycles"] == 0, "level 0 relaxed"
    assert m["solver_failures"] == 0
    assert m["collision_distance_min"] >= safety - 1e-3, m["collision_closest"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_crossing_holds_under_rounding_perturbations(seed):
    m, safety = _run(seed, "pinocchio", 2.5, pole_ratio=1.5)
    _check(m, safety)
    assert m["collision_pairs_active_max"] >= 1


#: the perturbation seeds of the damper's comparison
SEEDS = (1, 2, 3, 4, 5, 6, 7, 8)


@pytest.mark.slow
def test_switching_drift_holds_the_crossing_on_every_seed_where_the_exact_drift_relaxes():
    # the scenario as bundled: the critically damped damper (pole_ratio 1) with ``drift: switching``, whose rows take
    # the hull features' switches at the crossing as jumps of ḋ and the pieces' curvature as the largest of the
    # one-sided differences over ±10 ms and ±0.25 ms and the second differences centred at ±0.25 ms
    # (wbc.collision.drift.switch_jump). First 2.5 s, own simulator: the exact drift relaxed 56 cycles in all over
    # seeds 1-5 (22, 5, 6, 2, 21) on pinocchio 4.1 and 58 (7, 2, 6, 21, 22) on 3.8; switching with the ±10 ms
    # differences alone 17 (4, 3, 0, 5, 5) and 7 (0, 0, 3, 2, 2), where switches fell on both sides of the window
    # (a = −4 to −7 m/s², the pieces curving at +1 to +2.6); with the short ones none on seeds 1-8 on either version
    # (benchmarks/collisions.md, hands4). Which seed relaxes without them is a rounding lottery, so nothing is
    # asserted of that; the exact drift's total shows that the crossing still exercises the defect.
    sc = load_config("talos_hands_cross")
    task = next(t for t in sc.stack if t.kind == "collision_avoidance")
    assert task.pole_ratio == 1.0 and task.drift == "switching" and task.model.switch_step
    relaxed = {}
    for drift, seeds in (("switching", SEEDS), ("exact", SEEDS[:5])):
        relaxed[drift] = []
        for seed in seeds:
            m, safety = _run(seed, "pinocchio", 2.5, drift=drift)
            assert not m["fell"] and m["solver_failures"] == 0
            assert m["collision_distance_min"] >= safety - 1e-3, m["collision_closest"]
            relaxed[drift].append(m["relaxed_cycles"])
    assert sum(relaxed["exact"]) >= 20, relaxed           # the crossing still exercises the defect
    assert sum(relaxed["switching"]) == 0, relaxed
