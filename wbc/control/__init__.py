"""The chapter's controllers outside the stack of tasks (5.2, 5.3).

Motion control (5.2): joint space (:mod:`.joint_space`), elastic joints
(:mod:`.elastic_joints`), task space (:mod:`.task_space`). Every rigid-body
controller is an object ``(q, v, t) -> τ``; see :mod:`.motion_common`.
"""

from .elastic_joints import ElasticJointController, MotorPD, TorqueFeedback
from .impedance import ImpedanceControl
from .joint_space import (
    InverseDynamics,
    PassivityBased,
    PDGravity,
    PDPlus,
    dynamic_parameters,
    slotine_li_regressor,
)
from .motion_common import ControllerDefinitionError, MotionController, Reference
from .null_space_impedance import NullSpaceImpedance
from .stiffness import StiffnessControl
from .task_space import (
    ExtendedTaskSpace,
    JacobianTransposePD,
    OperationalSpace,
    TaskSpaceInverseDynamics,
    extended_task_space,
)

__all__ = [
    "ControllerDefinitionError",
    "ElasticJointController",
    "ExtendedTaskSpace",
    "ImpedanceControl",
    "InverseDynamics",
    "JacobianTransposePD",
    "MotionController",
    "MotorPD",
    "NullSpaceImpedance",
    "OperationalSpace",
    "PDGravity",
    "PDPlus",
    "PassivityBased",
    "Reference",
    "StiffnessControl",
    "TaskSpaceInverseDynamics",
    "TorqueFeedback",
    "dynamic_parameters",
    "extended_task_space",
    "slotine_li_regressor",
]
