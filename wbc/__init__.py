"""wbc: whole-body multi-priority control on Pinocchio.

    import wbc
    robot = wbc.load_robot("talos")
    stack = wbc.Stack([[wbc.tasks.JointLimits(), wbc.tasks.Contact("left_foot"), ...], ...])
    ctrl = wbc.Controller(robot, stack, solver="hqp")
    sol = ctrl.solve(q, v)
"""

from . import tasks
from .controller import Controller
from .errors import (
                     ConfigError,
                     FrameNotFound,
                     RobotDefinitionError,
                     RobotNotFound,
                     SolverError,
                     StackError,
                     TargetError,
                     TaskDefinitionError,
                     WbcError,
)
from .kernel_cache import drop_stale as _drop_stale
from .model import RobotModel
from .robots import available_robots, load_robot
from .scenario import Scenario, load_config
from .solution import Solution
from .stack import Stack

__version__ = "0.1.0"

__all__ = [
    "tasks", "Controller", "load_config", "Scenario", "Stack", "Solution", "RobotModel", "load_robot", "available_robots",
    "WbcError", "RobotNotFound", "RobotDefinitionError", "FrameNotFound", "TaskDefinitionError",
    "TargetError", "StackError", "ConfigError", "SolverError",
]

# before any kernel is loaded (at its first call): caches of changed kernel files are dropped
_drop_stale()
