"""A force task's desired and measured forces where they act, for both views."""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def task_forces(robot, data, task, stack) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(point, desired, measured) of a force task: its contact's point (m, world) and the forces
    S_f λ_D and S_f λ_m (N, world; their force part for a surface contact; measured None before
    the task's first measurement), at the joint placements of ``data`` (forward kinematics done).

    Args:
        robot: the :class:`~wbc.robot.RobotModel`.
        data: a ``pinocchio.Data`` of its model, joints placed.
        task: the force task.
        stack: its stack (the task's contact).
    """
    surface = stack[task.contact].surface(robot)
    fid = robot.frame_id(surface.frame)
    pin.updateFramePlacement(robot.model, data, fid)
    M = data.oMf[fid]
    S = task.selection(surface.force_dim)[0]
    R = np.eye(3) if surface.force_dim == 3 else M.rotation     # a surface's forces: LOCAL
    desired = R @ (S @ task.reference())[:3]
    measured = None if task.measured is None else R @ (S @ (S.T @ task.measured))[:3]
    return M.translation.copy(), desired, measured
