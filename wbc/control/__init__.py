"""The chapter's controllers outside the stack of tasks (5.2, 5.3).

Motion control (5.2): joint space (:mod:`.joint_space`), elastic joints
(:mod:`.elastic_joints`), task space (:mod:`.task_space`). Every rigid-body
controller is an object ``(q, v, t) -> τ``; see :mod:`.motion_common`.
"""

from .joint_space import (
    InverseDynamics,
    PassivityBased,
    PDGravity,
    PDPlus,
    dynamic_parameters,
    slotine_li_regressor,
)
from .motion_common import ControllerDefinitionError, MotionController, Reference

__all__ = [
    "ControllerDefinitionError",
    "InverseDynamics",
    "MotionController",
    "PDGravity",
    "PDPlus",
    "PassivityBased",
    "Reference",
    "dynamic_parameters",
    "slotine_li_regressor",
]
