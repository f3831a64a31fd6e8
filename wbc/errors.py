"""Exception types of wbc.

Every error a user can cause names what was wrong (robot, frame, task, key path)
and what was expected, so it can be fixed without reading the source.

An error may carry its parts (all optional): ``key``, the key path of the bad value
(``"kp"`` inside a task's constructor, ``"stack[1][0].kp"`` once a scenario loader has
placed it), ``owner`` (``"task 'com'"``, for errors raised outside any file), ``file`` and
``line`` (1-based, where the YAML loader knew it). ``str(error)`` joins them:

    tasks/talos_balance.yaml:17: stack[1][0].kp: must be a number >= 0 ..., got 'fast'
    task 'com': kp must be a number >= 0 ..., got 'fast'
"""

from __future__ import annotations

from pathlib import Path
from typing import overload


class WbcError(Exception):
    """Base class of every error raised by wbc."""

    def __init__(self, message: str = "", *, key: str | None = None, owner: str | None = None,
                 file: str | Path | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.key, self.owner, self.file, self.line = key, owner, file, line

    def __str__(self) -> str:
        text = self.message
        if self.key:
            # "task 'com': kp must be ..." reads as a sentence; a key path in a file as "path: ..."
            text = f"{self.key} {text}" if self.owner and self.file is None else f"{self.key}: {text}"
        if self.owner and self.file is None:
            text = f"{self.owner}: {text}"
        if self.file is not None:
            text = f"{self.file}{f':{self.line}' if self.line else ''}: {text}"
        return text


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


class HybridError(StackError):
    """A hybrid force/motion pair whose force and motion directions are not reciprocal
    (S_fᵀ S_v ≠ 0, 5.33), or that names tasks the stack does not have."""


class ConfigError(WbcError):
    """A YAML scenario that does not validate; names file, key path, expectation."""


class SolverError(WbcError):
    """A solver that could not produce a finite solution."""


class ControllerDefinitionError(WbcError):
    """A controller of :mod:`wbc.chapter` built with wrong parameters: a gain that is not
    positive (semi)definite, of the wrong size, or not finite; an unknown option."""


class ObserverError(WbcError):
    """A momentum observer (:mod:`wbc.interaction.momentum_observer`) used wrongly: a bad gain, an update
    before reset, time not increasing."""


class ElasticSimulationError(WbcError):
    """Bad elastic-joint parameters (sizes, signs) or a step too long for the stiffness
    (:mod:`wbc.sim.elastic`)."""


class PlotError(WbcError):
    """A metrics file with no usable time series (``wbc plot``)."""


class HarnessNotFound(WbcError):
    """``wbc bench`` without the benchmark harness (``benchmarks/harness/`` of the source
    tree, which a wheel does not ship)."""


class RobotWarning(UserWarning):
    """A robot YAML that loads but describes a robot that will struggle (a joint whose
    static torque exceeds its limit, a posture outside the limits, a contact not facing
    the ground); issued by :func:`wbc.robot.extras.check_robot` at load time."""


class CollisionWarning(UserWarning):
    """A run whose robot starts with a monitored pair closer than the collision task's
    safety distance (or in penetration): the pair and its distance are named; the task's
    damper pushes the pair out (:class:`wbc.runner.observers.CollisionObserver`)."""


@overload
def join_key(prefix: str | None, key: str) -> str: ...
@overload
def join_key(prefix: str | None, key: str | None) -> str | None: ...
def join_key(prefix: str | None, key: str | None) -> str | None:
    """The key path ``key`` below ``prefix``: ``join_key("stack[1][0]", "kp")`` is
    ``"stack[1][0].kp"``, ``join_key("stack", "[1]")`` is ``"stack[1]"``."""
    if not prefix:
        return key
    if not key:
        return prefix
    return f"{prefix}{key}" if key.startswith("[") else f"{prefix}.{key}"


def placed(exc: WbcError, prefix: str | None = None, *, file: str | Path | None = None,
           line: int | None = None, cls: type[WbcError] | None = None) -> WbcError:
    """``exc`` re-raised one level up: its key path below ``prefix``, in ``file`` (at
    ``line``), as ``cls`` (default: its own class). An error that already names its own
    file (a robot YAML's, inside a scenario) keeps that text whole as the message of the
    key ``prefix``."""
    cls = cls or type(exc)
    if exc.file is not None:                       # an error of another file, quoted whole
        return cls(str(exc), key=prefix, file=file, line=line)
    if exc.key is None and exc.owner is None:     # a plain-text error: its text, at prefix
        return cls(exc.message or str(exc), key=prefix, file=file, line=line)
    key = join_key(prefix, exc.key)
    message = exc.message
    if exc.owner and prefix is None and file is None:
        return cls(message, key=exc.key, owner=exc.owner)
    return cls(message, key=key, file=file, line=line)
