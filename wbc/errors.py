"""Exception types of wbc.

Every error a user can cause names what was wrong (robot, frame, task, key path)
and what was expected, so it can be fixed without reading the source.
"""

from __future__ import annotations


class WbcError(Exception):
    """Base class of every error raised by wbc."""


class RobotNotFound(WbcError):
    """A robot name or path that resolves to no robot YAML."""


class RobotDefinitionError(WbcError):
    """A robot YAML that is malformed or points at a missing URDF/SRDF."""


class FrameNotFound(WbcError):
    """A frame name (or alias) the robot does not have."""


class TaskDefinitionError(WbcError):
    """A task built with wrong parameters (negative gain, unknown axis, ...)."""


class TargetError(WbcError):
    """A task target of the wrong shape or type."""


class StackError(WbcError):
    """A stack that is malformed (duplicate names, unknown task, missing contact)."""


class ConfigError(WbcError):
    """A YAML scenario that does not validate; names file, key path, expectation."""


class SolverError(WbcError):
    """A solver that could not produce a finite solution."""
