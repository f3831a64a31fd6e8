"""No torque beyond a limit is ever returned, and never a NaN.

Whatever the solver and whatever went wrong (a relaxed level, the projection solver's
unenforced torque limits, a stack without TorqueLimits, a non-finite solve), ``sol.tau``
is finite and inside ±τ_max; a cycle whose solver asked for more is saturated and says so
(``status``, ``saturated``, ``tau_ratio``, the joints in ``saturated_torques`` and in the
diagnostics of the level holding the torque limits). Checked over random states with
targets within reach and far beyond it, on Talos with its URDF limits and with the
limits cut to 5 % (gravity cannot be held: every solve is infeasible).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.helpers.stacks import random_state, randomise_targets, talos_stack
from wbc.tasks import CoM, Contact, JointLimits, Posture, TorqueLimits

N_STATES = 25


def _unreachable(stack: wbc.Stack, robot, rng) -> None:
    """Targets no robot reaches: the CoM 0.6 m away, the hands 1.5 m, stiff gains."""
    stack["com"].target = robot.com + rng.choice([-1, 1], 3) * 0.6
    for name in ("right_hand", "left_hand"):
        M = robot.frame_placement(robot.frame_id(name))
        stack[name].target = pin.SE3(M.rotation, M.translation + 1.5 * rng.standard_normal(3))
        stack[name].set_gains(2000.0)


def _check(sol, robot, counts) -> None:
    a = robot.actuated_idx
    lim = robot.tau_max[a]
    for arr in (sol.tau, sol.tau_full, sol.qdd, sol.x, *sol.forces.values()):
        assert np.all(np.isfinite(arr)), f"non-finite output ({sol.status}: {sol.message})"
    assert np.all(np.abs(sol.tau) <= lim), f"|τ| / τ_max = {np.max(np.abs(sol.tau) / lim):.6g}"
    assert np.all(sol.tau_full[robot.unactuated_idx] == 0.0)
    asked = sol.tau_ratio > 1.0 + 2e-6
    assert sol.saturated == asked or (sol.saturated and sol.status == "failed")
    if sol.saturated:
        assert sol.status in ("saturated", "failed") and "τ saturated" in sol.message
        held = np.flatnonzero(np.abs(sol.tau_full) >= robot.tau_max * (1 - 1e-12)).tolist()
        assert sol.saturated_torques == held != []
        reported = [d for d in sol.diagnostics if d.saturated_torques]
        assert len(reported) == 1 and reported[0].saturated_torques == held
        assert reported[0].active["torque_saturation"] == len(held)
        torque_level = next((d for d in sol.diagnostics if "torque_limits" in d.tasks), sol.diagnostics[0])
        assert reported[0] is torque_level
    else:
        assert sol.status != "saturated" and not sol.saturated_torques
    counts[sol.status] += 1
    counts["saturated"] += sol.saturated
    counts["relaxed"] += sol.relaxed


@pytest.fixture(scope="module")
def weak_talos():
    """Talos with 5 % of its torque limits: it cannot even hold its own weight."""
    robot = wbc.load_robot("talos")
    robot.tau_max = robot.tau_max * 0.05
    return robot


@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
@pytest.mark.parametrize("limits", ["urdf", "weak"])
def test_returned_torque_is_finite_and_inside_the_limits(talos, weak_talos, solver, limits, rng):
    from collections import Counter

    robot = talos if limits == "urdf" else weak_talos
    counts = Counter()
    for i in range(N_STATES):
        q, v = random_state(robot, rng, speed=0.5)
        stack = talos_stack(torque_limits=i % 3 != 0)      # some stacks without TorqueLimits
        robot.update(q, v)
        if i % 2:
            _unreachable(stack, robot, rng)
        else:
            randomise_targets(stack, robot, rng)
        ctrl = wbc.Controller(robot, stack, solver=solver)
        for _ in range(3):                                  # the same controller, cycle after cycle
            _check(ctrl.solve(q, v), robot, counts)
    print(f"\n{solver}, {limits} limits: {dict(counts)}")
    assert counts["saturated"] > 0                          # the saturation was exercised
    if limits == "weak":
        # gravity cannot be held: every solver asks beyond the limits, most of the time
        assert counts["saturated"] >= 0.5 * 3 * N_STATES
        if solver != "projection":
            assert counts["relaxed"] > 0


@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
def test_a_failed_solve_falls_back_inside_the_limits(weak_talos, solver):
    """A non-finite solve (an infinite gain: rows of inf) fails; the fallback torque (the
    last good one, or gravity compensation on the first cycle, which 5 % limits cannot
    give) is saturated too, and q̈, the forces and x are finite."""
    robot = weak_talos
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    stack = wbc.Stack([[JointLimits(), TorqueLimits(), Contact("left_foot"), Contact("right_foot")],
                       [CoM(kp=100.0)], [Posture(kp=1e308)]])
    robot.update(q, v)
    q_far = q.copy()
    q_far[7:] += 3.0                                       # 1e308 × 3 rad = inf
    stack["posture"].target = q_far
    ctrl = wbc.Controller(robot, stack, solver=solver)
    from collections import Counter

    counts = Counter()
    sol = ctrl.solve(q, v)
    assert sol.status == "failed"
    _check(sol, robot, counts)
    assert sol.saturated                                     # g(q) is beyond 5 % of the limits
    assert np.all(sol.qdd == 0.0)


def test_saturation_keeps_the_sign_and_clips_only_what_is_beyond(weak_talos):
    """The saturated torque is the solver's, clipped joint by joint: joints inside their
    limits keep their value, the others sit at ±τ_max with the sign asked."""
    robot = weak_talos
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    stack = talos_stack(torque_limits=False)
    robot.update(q, v)
    ctrl = wbc.Controller(robot, stack, solver="hqp")
    sol = ctrl.solve(q, v)
    assert sol.status == "saturated"
    a = robot.actuated_idx
    Jf = ctrl.layout.force_jacobian
    planned = (robot.M @ sol.qdd + robot.h - Jf.T @ sol.x[robot.nv:])[a]
    lim = robot.tau_max[a]
    np.testing.assert_allclose(sol.tau, np.clip(planned, -lim, lim), rtol=0, atol=1e-9)
    beyond = np.abs(planned) > lim
    assert beyond.any() and (~beyond).any()
    assert np.all(np.sign(sol.tau[beyond]) == np.sign(planned[beyond]))
    assert sol.tau_ratio == pytest.approx(np.max(np.abs(planned) / lim), rel=1e-9)
