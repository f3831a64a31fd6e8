"""Peer check: PlaCo's KinematicsSolver and wbc solve the same Talos IK problem
(feet fixed, CoM over the middle of the feet, a reachable hand target) and land on
the same hand position, each within 1 mm of the target."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.robot.loader import package_share_dir
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture

pytest.importorskip("placo", reason="PlaCo is an optional peer: the [peers] extra, installable with pinocchio 3.8 only")
from benchmarks.harness import placo_peer  # noqa: E402  (needs placo)


@pytest.mark.parametrize("offset", [(0.10, 0.0, 0.10), (0.05, -0.10, -0.05)])
def test_wbc_and_placo_reach_the_same_hand_target(talos, offset):
    q0 = talos.q_default.copy()
    talos.update(q0, np.zeros(talos.nv))
    hand = talos.frame_placement(talos.frame_id("right_hand")).translation
    target = hand + np.array(offset)
    lf = talos.frame_placement(talos.frame_id("left_foot")).translation
    rf = talos.frame_placement(talos.frame_id("right_foot")).translation
    mid = 0.5 * (lf + rf)

    peer = placo_peer.placo_talos_hand_ik(str(talos.urdf_path), str(package_share_dir("example-robot-data")),
                                          q0, talos.frames["right_hand"], target)

    stack = wbc.Stack([
        [JointLimits(), Contact("left_foot"), Contact("right_foot")],
        [CoM(kp=100.0, axes="xy", target=[mid[0], mid[1], 0.0])],
        [Frame("right_hand", kp=100.0, mask="position", target=target)],
        [Posture(kp=10.0, target=q0)],
    ])
    ctrl = wbc.Controller(talos, stack, solver="hqp")
    q, v, dt = q0.copy(), np.zeros(talos.nv), 1e-3
    for _ in range(3000):
        sol = ctrl.solve(q, v)
        assert sol.ok, sol.message
        v = v + sol.qdd * dt
        q = pin.integrate(talos.model, q, v * dt)
    talos.update(q, v)
    ours = talos.frame_placement(talos.frame_id("right_hand")).translation
    ours_err = float(np.linalg.norm(ours - target))
    print(f"offset {offset}: wbc hand error {ours_err * 1e3:.3f} mm, PlaCo {peer['hand_error'] * 1e3:.3f} mm, "
          f"hand positions differ by {np.linalg.norm(ours - peer['hand_position']) * 1e3:.3f} mm")
    assert ours_err < 1e-3 and peer["hand_error"] < 1e-3
    assert abs(ours_err - peer["hand_error"]) < 1e-3
    assert np.linalg.norm(talos.com[:2] - mid[:2]) < 1e-3
