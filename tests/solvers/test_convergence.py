"""Invariant 4 (kinematic form): integrating q̈ as a double integrator, each feasible
task error obeys ë + K_d ė + K_p e = 0 (5.17). With K_d = 2√K_p, a constant target
and zero initial velocity the error is e(t) = e₀ (1 + ωt) e^{−ωt}, ω = √K_p."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture

DT = 1e-3


def _critically_damped(e0: np.ndarray, kp: float, t: float) -> np.ndarray:
    w = np.sqrt(kp)
    return e0 * (1.0 + w * t) * np.exp(-w * t)


def _run(robot, ctrl, q, v, tasks, duration):
    """Double-integrate q̈; record each named task's error."""
    hist = {name: [] for name in tasks}
    for _ in range(int(round(duration / DT))):
        sol = ctrl.solve(q, v)
        assert sol.ok, sol.message
        for name in tasks:
            hist[name].append(ctrl.stack[name].error(robot).copy())
        v = v + sol.qdd * DT
        q = pin.integrate(robot.model, q, v * DT)
    return {k: np.array(h) for k, h in hist.items()}, q, v


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_talos_task_errors_follow_the_closed_loop_the_gains_set(talos, solver):
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    stack = wbc.Stack([
        [JointLimits(), Contact("left_foot"), Contact("right_foot")],
        [CoM(kp=100.0)],
        [Frame("right_hand", kp=50.0), Frame("left_hand", kp=50.0)],
        [Posture(kp=10.0)],
    ])
    talos.update(q, v)
    stack["com"].target = talos.com + np.array([0.0, 0.02, -0.02])
    hand = talos.frame_placement(talos.frame_id("right_hand"))
    stack["right_hand"].target = hand.translation + np.array([0.06, 0.0, 0.04])
    ctrl = wbc.Controller(talos, stack, solver=solver)
    hist, q, v = _run(talos, ctrl, q, v, ["com", "right_hand", "left_foot_contact"], 1.5)
    t = np.arange(len(hist["com"])) * DT
    for name, kp in (("com", 100.0), ("right_hand", 50.0)):
        e = hist[name]
        model = np.array([_critically_damped(e[0], kp, ti) for ti in t])
        dev = np.abs(e - model).max() / np.abs(e[0]).max()
        print(f"{solver} {name}: max deviation from e0 (1 + ωt) e^(-ωt) {dev:.2%} of |e0|")
        assert dev < 0.02, f"{name}: deviates {dev:.1%} from e0 (1 + ωt) e^(-ωt)"
        assert np.linalg.norm(e[-1]) < 1e-3 * np.linalg.norm(e[0]) + 1e-6
    # the feet stay put up to the O(dt²) drift of explicit integration (0.5 mm)
    assert np.abs(hist["left_foot_contact"]).max() < 5e-4


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_tiago_hand_converges_and_base_never_slides_sideways(tiago, solver):
    q, v = tiago.q_default.copy(), np.zeros(tiago.nv)
    stack = wbc.Stack([
        [JointLimits()],
        [Frame("hand", kp=25.0, mask="position")],
        [Posture(kp=10.0)],
    ])
    tiago.update(q, v)
    hand = tiago.frame_placement(tiago.frame_id("hand")).translation
    stack["hand"].target = hand + np.array([0.10, 0.05, -0.05])
    ctrl = wbc.Controller(tiago, stack, solver=solver)
    hist, q, v = _run(tiago, ctrl, q, v, ["hand"], 2.0)
    e = hist["hand"]
    t = np.arange(len(e)) * DT
    model = np.array([_critically_damped(e[0], 25.0, ti) for ti in t])
    dev = np.abs(e - model).max() / np.abs(e[0]).max()
    print(f"tiago {solver} hand: max deviation from e0 (1 + ωt) e^(-ωt) {dev:.2%} of |e0|")
    assert dev < 0.02
    assert abs(v[1]) < 1e-9           # differential drive: no lateral base velocity
