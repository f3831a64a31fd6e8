"""The chapter's controllers outside the stack of tasks (5.2, 5.3).

Motion control (5.2): joint space (:mod:`.joint_space`; independent-joint PID with
decentralised or centralised feedforward, :mod:`.independent_joint`; robust
Slotine-Li, :mod:`.robust_passivity`), elastic joints
(:mod:`.elastic_joints`), task space (:mod:`.task_space`). Every rigid-body
controller is an object ``(q, v, t) -> τ``; see :mod:`.motion_common`.

Force control (5.3): stiffness (:mod:`.stiffness`), impedance (:mod:`.impedance`),
admittance (:mod:`.admittance`), hybrid force/motion (:mod:`.hybrid_force_motion`),
multi-priority interaction (:mod:`.null_space_impedance`); those with force
feedback are called ``(q, v, t, h_e=...) -> τ`` (conventions in :mod:`._opspace`).

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.robot`, :mod:`wbc.null_space`,
:mod:`wbc.sim` (the elastic measurement). Nothing of the stack of tasks imports it.
"""

from .admittance import AdmittanceControl
from .elastic_joints import ElasticJointController, MotorPD, TorqueFeedback
from .hybrid_force_motion import HybridForceMotion
from .impedance import ImpedanceControl
from .independent_joint import IndependentJointPID
from .joint_space import (
    InverseDynamics,
    PassivityBased,
    PDGravity,
    PDPlus,
    dynamic_parameters,
    slotine_li_regressor,
)
from .motion_common import ControllerDefinitionError, MotionController, Reference
from .null_space_impedance import NullSpaceImpedanceController
from .robust_passivity import RobustPassivityBased, body_parameter_indices, body_parameter_scale, with_payload
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
    "IndependentJointPID",
    "InverseDynamics",
    "JacobianTransposePD",
    "MotionController",
    "MotorPD",
    "NullSpaceImpedanceController",
    "OperationalSpace",
    "PDGravity",
    "PDPlus",
    "PassivityBased",
    "Reference",
    "RobustPassivityBased",
    "StiffnessControl",
    "TaskSpaceInverseDynamics",
    "TorqueFeedback",
    "body_parameter_indices",
    "body_parameter_scale",
    "dynamic_parameters",
    "extended_task_space",
    "slotine_li_regressor",
    "with_payload",
]
