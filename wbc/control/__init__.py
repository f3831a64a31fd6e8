"""The chapter's controllers outside the stack of tasks (5.2, 5.3).

Motion control (5.2): joint space (:mod:`.joint_space`), elastic joints
(:mod:`.elastic_joints`), task space (:mod:`.task_space`). Every rigid-body
controller is an object ``(q, v, t) -> τ``; see :mod:`.motion_common`.

Force control (5.3): stiffness (:mod:`.stiffness`), impedance (:mod:`.impedance`),
admittance (:mod:`.admittance`), hybrid force/motion (:mod:`.hybrid_force_motion`),
multi-priority interaction (:mod:`.null_space_impedance`); those with force
feedback are called ``(q, v, t, h_e=...) -> τ`` (conventions in :mod:`._opspace`).
"""

from .admittance import AdmittanceControl
from .elastic_joints import ElasticJointController, MotorPD, TorqueFeedback
from .hybrid_force_motion import HybridForceMotion
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
    "AdmittanceControl",
    "ControllerDefinitionError",
    "ElasticJointController",
    "ExtendedTaskSpace",
    "HybridForceMotion",
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
