"""PlaCo reference ("peer") solver for the Talos hand-reaching IK problem.

The IK peer problem: the tests and `wbc bench` call :func:`placo_talos_hand_ik` to get an
independent solution of the same whole-body IK problem that ``wbc`` solves.

Units: positions in metres, angles in radians, times in milliseconds.
Configurations are returned in *pinocchio* order (nq=39 for Talos: free-flyer
``[x, y, z, qx, qy, qz, qw]`` followed by the revolute joints).
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np
import pinocchio as pin
import placo

SOLES: tuple[str, str] = ("left_sole_link", "right_sole_link")


def _joint_q_slices(model: pin.Model) -> dict[str, slice]:
    """Map joint name -> slice into q (all joints except 'universe')."""
    return {
        model.names[j]: slice(model.idx_qs[j], model.idx_qs[j] + model.nqs[j])
        for j in range(1, model.njoints)
    }


def _pin_to_placo(q_pin: np.ndarray, pin_model: pin.Model, placo_model: pin.Model) -> np.ndarray:
    """Reorder a pinocchio configuration into PlaCo's q layout, matching joints by name."""
    src, dst = _joint_q_slices(pin_model), _joint_q_slices(placo_model)
    q = pin.neutral(placo_model)
    for name, s in dst.items():
        q[s] = q_pin[src[name]]
    return q


def _placo_to_pin(q_placo: np.ndarray, placo_model: pin.Model, pin_model: pin.Model) -> np.ndarray:
    """Inverse of :func:`_pin_to_placo`."""
    return _pin_to_placo(q_placo, placo_model, pin_model)


def placo_talos_hand_ik(
    urdf_path: str,
    package_dir: str,
    q_start: np.ndarray,
    hand_frame: str,
    hand_target_world: np.ndarray,
    iterations: int = 400,
    dt: float = 0.01,
    *,
    posture_weight: float = 1e-4,
) -> dict[str, Any]:
    """Solve the Talos two-feet hand-reaching IK with PlaCo's ``KinematicsSolver``.

    Tasks (PlaCo priorities):
      * both soles (``left_sole_link``, ``right_sole_link``): hard 6D frame tasks at
        their placement at ``q_start``;
      * CoM: hard xy task at the midpoint of the two soles' xy (m);
      * ``hand_frame`` position: soft task (weight 1) to ``hand_target_world`` (m, world);
      * posture: soft joints task (weight ``posture_weight``) towards ``q_start``'s
        joint values (rad).
    Joint limits are enabled (PlaCo default). Iterates ``solver.solve(True)`` +
    ``robot.update_kinematics()`` until the step norm is < 1e-9 or ``iterations``.

    Args:
        urdf_path: Talos URDF file.
        package_dir: directory containing ``example-robot-data/`` (for ``package://``).
        q_start: pinocchio-ordered start configuration, shape (39,).
        hand_frame: frame whose position is driven (e.g. ``gripper_right_base_link``).
        hand_target_world: target position (3,), metres, world frame.
        iterations: max number of solver iterations.
        dt: solver time step (s); only matters if velocity limits are enabled.
        posture_weight: soft weight of the posture task (hand task weight is 1);
            the converged hand error scales roughly linearly with it (1e-4 -> ~0.1 mm).

    Returns:
        dict with ``q`` (pinocchio order, (39,)), ``hand_position`` ((3,), m),
        ``hand_placement`` ((4, 4) homogeneous world transform, m),
        ``hand_error`` (m), ``left_sole_drift`` / ``right_sole_drift`` (m, position
        only), ``com_xy_error`` (m), ``solve_ms_median`` (ms per
        ``solver.solve`` call), ``iterations`` (int, solves performed).
    """
    os.environ["ROS_PACKAGE_PATH"] = package_dir
    q_start = np.asarray(q_start, dtype=float)
    target = np.asarray(hand_target_world, dtype=float).reshape(3)

    pin_model = pin.buildModelFromUrdf(urdf_path, pin.JointModelFreeFlyer())
    robot = placo.RobotWrapper(urdf_path, placo.Flags.ignore_collisions)
    pmodel = robot.model
    robot.state.q = _pin_to_placo(q_start, pin_model, pmodel)
    robot.update_kinematics()

    solver = placo.KinematicsSolver(robot)
    solver.dt = dt
    solver.mask_fbase(False)  # floating base is free (default), stated explicitly
    solver.enable_joint_limits(True)

    T_soles0 = {f: robot.get_T_world_frame(f).copy() for f in SOLES}
    for f in SOLES:
        solver.add_frame_task(f, T_soles0[f]).configure(f, "hard", 1.0, 1.0)

    support_xy = 0.5 * (T_soles0[SOLES[0]][:2, 3] + T_soles0[SOLES[1]][:2, 3])
    com = solver.add_com_task(np.array([support_xy[0], support_xy[1], 0.0]))
    com.mask.set_axises("xy")
    com.configure("com_xy", "hard", 1.0)

    hand = solver.add_position_task(hand_frame, target)
    hand.configure("hand", "soft", 1.0)

    posture = solver.add_joints_task()
    posture.set_joints({name: robot.get_joint(name) for name in robot.joint_names()})
    posture.configure("posture", "soft", posture_weight)

    times_ms: list[float] = []
    for _ in range(iterations):
        t0 = time.perf_counter()
        dq = solver.solve(True)
        times_ms.append((time.perf_counter() - t0) * 1e3)
        robot.update_kinematics()
        if np.linalg.norm(dq) < 1e-9:
            break

    hand_T = np.array(robot.get_T_world_frame(hand_frame))
    hand_pos = hand_T[:3, 3].copy()
    drift = {
        f: float(np.linalg.norm(robot.get_T_world_frame(f)[:3, 3] - T_soles0[f][:3, 3]))
        for f in SOLES
    }
    return {
        "q": _placo_to_pin(np.array(robot.state.q), pmodel, pin_model),
        "hand_position": hand_pos,
        "hand_placement": hand_T,
        "hand_error": float(np.linalg.norm(hand_pos - target)),
        "left_sole_drift": drift[SOLES[0]],
        "right_sole_drift": drift[SOLES[1]],
        "com_xy_error": float(np.linalg.norm(robot.com_world()[:2] - support_xy)),
        "solve_ms_median": float(np.median(times_ms)) if times_ms else float("nan"),
        "iterations": len(times_ms),
    }


if __name__ == "__main__":
    share = os.path.join(os.path.dirname(pin.__file__), *[".."] * 4, "share")
    share = os.path.normpath(share)
    talos = os.path.join(share, "example-robot-data", "robots", "talos_data")
    urdf = os.path.join(talos, "robots", "talos_reduced.urdf")
    model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    pin.loadReferenceConfigurations(model, os.path.join(talos, "srdf", "talos.srdf"))
    q0 = model.referenceConfigurations["half_sitting"].copy()
    data = model.createData()
    frame = "gripper_right_base_link"
    fid = model.getFrameId(frame)
    pin.framesForwardKinematics(model, data, q0)
    target = data.oMf[fid].translation + np.array([0.10, 0.0, 0.10])

    out = placo_talos_hand_ik(urdf, share, q0, frame, target)
    for k, v in out.items():
        print(f"{k}: {v}")

    # Cross-check: pinocchio FK on the returned (pinocchio-ordered) q must match PlaCo.
    pin.framesForwardKinematics(model, data, out["q"])
    gap = float(np.abs(data.oMf[fid].homogeneous - out["hand_placement"]).max())
    print(f"pinocchio vs placo hand placement max abs gap: {gap:.3e}")
    assert gap < 1e-9, gap
