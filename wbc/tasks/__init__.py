"""Task library: one task kind per module. Each returns affine rows over x = (q̈, f).

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.robot`, :mod:`wbc.problem`,
:mod:`wbc.null_space`, :mod:`wbc.cholesky`. Not the stack (the sugar is :mod:`.group`), the controller or the chapter.
"""

from .base import MotionTask, Task
from .collision_avoidance import CollisionAvoidance
from .com import CoM
from .contact import Contact, friction_pyramid, wrench_cone, wrench_cone_generators
from .contact_regularization import ContactRegularization
from .contact_wrench import ContactWrench
from .dynamics import DifferentialDrive, FloatingBaseDynamics
from .force import Force
from .frame import Frame
from .joint_limits import JointLimits
from .null_space_impedance import NullSpaceImpedance
from .posture import Posture
from .singularity_avoidance import SingularityAvoidance
from .torque_limits import TorqueLimits

#: task types a YAML stack may name, by their ``type:`` key
TASK_TYPES = {cls.kind: cls for cls in (JointLimits, TorqueLimits, Posture, CoM, Frame, Contact, ContactWrench,
                                        ContactRegularization, NullSpaceImpedance, Force,
                                        CollisionAvoidance, SingularityAvoidance)}

__all__ = [
    "Task", "MotionTask", "CoM", "CollisionAvoidance",
    "Contact", "ContactRegularization", "ContactWrench", "Force", "Frame", "JointLimits",
    "NullSpaceImpedance", "Posture", "SingularityAvoidance",
    "TorqueLimits", "FloatingBaseDynamics", "DifferentialDrive", "TASK_TYPES", "wrench_cone",
    "friction_pyramid", "wrench_cone_generators",
]
