"""Default task gains from the robot YAML (``gains:``), and the rule that carries them across robots.

Precedence, for a task of a scenario YAML (the stack and ``events: add``):

1. the task's own ``kp`` (and ``kd``) in the scenario;
2. the robot's ``gains:`` entry named like the task (``torso: 400`` for the task
   ``{type: frame, frame: torso}``, whose name is ``torso``);
3. the robot's ``gains:`` entry for the task's kind (``com``, ``frame``, ``posture``,
   ``contact`` ...);
4. the task class's own default (``wbc tasks``).

A gain kp (1/s²) is the square of the closed-loop natural frequency of the task's error
dynamics, ë + kd ė + kp e = 0 (eq. 5.17): ω = √kp (rad/s), and kd = 2ζω with ζ = 1
(critically damped) unless the task gives ``kd``. Tasks are acceleration-level, so the
same ω gives the same error response on any robot whatever its mass (the torques scale
with the inertia through M(q) in the solver); what does differ between robots is how much
of a disturbance each ω rejects before a contact or a torque limit gives way
(docs/robots.md).
"""

from __future__ import annotations

import math

from .tasks.base import Task


def robot_gain(robot, task: Task) -> float | None:
    """The robot's default kp (1/s²) for ``task`` (module docstring, steps 2-3), or None."""
    gains = getattr(robot, "default_gains", None) or {}
    for key in (task.name, task.kind):
        if key in gains:
            return float(gains[key])
    return None


def apply_robot_gains(task: Task, spec: dict, robot) -> None:
    """Give ``task`` (built from the scenario mapping ``spec`` and bound) the robot's
    default kp when ``spec`` has none; kd then is ``spec``'s, or 2√kp (ζ = 1)."""
    if not hasattr(task, "set_gains") or "kp" in spec:
        return
    kp = robot_gain(robot, task)
    if kp is not None:
        task.set_gains(kp, spec.get("kd"))


def natural_frequency(kp: float) -> float:
    """ω = √kp (rad/s) of a task gain kp (1/s²)."""
    return math.sqrt(kp)
