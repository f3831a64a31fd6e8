"""wbc: whole-body multi-priority control on Pinocchio.

    import wbc
    robot = wbc.load_robot("talos")
    stack = wbc.Stack([[wbc.tasks.JointLimits(), wbc.tasks.Contact("left_foot"), ...], ...])
    ctrl = wbc.Controller(robot, stack, solver="hqp")
    sol = ctrl.solve(q, v)
    metrics = wbc.run(wbc.load_config("talos_balance"), duration=1.0)

The public API is :data:`__all__`, listed with its modules in docs/architecture.md ("The
public API"); import paths that changed in the layout change are in CHANGELOG.md.
"""

from wbc.controller.cycle import Controller
from wbc.controller.solution import Solution
from wbc.robot.loader import available_robots, load_robot
from wbc.robot.model import RobotModel
from wbc.runner.loop import run
from wbc.scenario.loader import Scenario, load_config

from . import tasks
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
from .stack import Stack

__version__ = "0.1.0"

__all__ = [
    "tasks", "Controller", "load_config", "Scenario", "Stack", "Solution", "RobotModel", "load_robot", "available_robots",
    "run",
    "WbcError", "RobotNotFound", "RobotDefinitionError", "FrameNotFound", "TaskDefinitionError",
    "TargetError", "StackError", "ConfigError", "SolverError",
]

# before any kernel is loaded (at its first call): caches of changed kernel files are dropped
_drop_stale()
