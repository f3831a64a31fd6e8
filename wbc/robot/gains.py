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

An entry may be ``auto`` instead of a number (:func:`auto_gains`): ``{torso: auto}`` derives the
kp of the orientation task of the frame ``torso`` from the robot's inertia, by the design rule
below, and ``{posture: auto}`` the posture's from it.

**The rule (a biped: a floating base on two feet).** A push of impulse J (N·s) at a frame at height
h_f above the support sets the whole body rotating about the support at J h_f / I_a (rad/s),
I_a the body's inertia about the horizontal (pitch) axis through the contacts' centre at
ground level (kg·m²: the centroidal inertia plus m times the squared CoM distance). A
critically damped loop at ω removes that rotation with a peak tilt of (J h_f / I_a) / (e ω).
An ``auto`` gain holds the peak tilt per unit impulse at :data:`TILT_PER_IMPULSE`:

    ω_frame = (h_f / I_a) / (e Θ),   kp = ω²,      Θ = 6.9·10⁻⁴ rad/(N·s),
    ω_posture = :data:`POSTURE_RATIO` · ω_frame,

Θ chosen so that Talos keeps its hand-tuned torso ω ≈ 7 rad/s (a 15 N·s push, 150 N for
0.1 s, tilts it 0.6°); the same rule gives the 33 kg G1 ω ≈ 23 rad/s, since the same push
turns it 3.3 times faster. The ratio of posture to torso frequency is Talos's (3.16 / 7.07).
The tipping rate is computed by pinocchio at the default posture, levelled on its contacts.
A quadruped does not tip about its feet's centre (they surround its CoM): the rule would
give the Go2 ω ≈ 84 rad/s, so ``auto`` is refused for any robot but a biped.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from wbc.errors import RobotDefinitionError

if TYPE_CHECKING:
    from wbc.tasks.base import Task

#: Θ (rad per N·s): an ``auto`` frame gain's peak tilt under a unit impulse at that frame
TILT_PER_IMPULSE = 6.9e-4
#: ω_posture / ω_frame of ``posture: auto``
POSTURE_RATIO = 0.447


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


def tipping_rate(model: pin.Model, q: np.ndarray, frame_id: int, contact_frame_ids: list[int]) -> float:
    """h_f / I_a (rad/s per N·s): the whole body's rate of rotation about the pitch axis
    through the contacts' centre at ground level per unit horizontal impulse at the frame
    (module docstring). ``q``: a configuration standing on the contacts."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    pin.ccrba(model, data, q, np.zeros(model.nv))          # data.Ig: centroidal inertia, data.com[0]
    feet = np.array([data.oMf[i].translation for i in contact_frame_ids])
    ground = np.array([feet[:, 0].mean(), feet[:, 1].mean(), feet[:, 2].min()])
    mass = data.Ig.mass
    c = data.com[0] - ground
    inertia = data.Ig.inertia[1, 1] + mass * (c[0] ** 2 + c[2] ** 2)
    height = data.oMf[frame_id].translation[2] - ground[2]
    return float(height / inertia)


def auto_gains(gains: dict, model: pin.Model, q: np.ndarray, frames: dict[str, str],
               contact_frames: list[str], has_floating_base: bool) -> dict[str, float]:
    """The robot YAML's ``gains:`` with each ``auto`` entry replaced by its kp (1/s², module
    docstring): a frame alias (``torso: auto``) by the frame rule, ``posture: auto`` by
    :data:`POSTURE_RATIO` times the ω of the (one) frame entry set to ``auto``. Raises
    :class:`~wbc.errors.RobotDefinitionError` naming the key when the rule does not apply."""
    out = {k: v for k, v in gains.items() if v != "auto"}
    auto = [k for k, v in gains.items() if v == "auto"]
    if not auto:
        return out
    if not (has_floating_base and len(contact_frames) == 2):
        raise RobotDefinitionError("'auto' derives a gain from how a biped tips about its two feet: it needs a "
                                   f"free-flyer root and two contacts (found {len(contact_frames)}); give a number "
                                   "(kp in 1/s²)", key=f"gains.{auto[0]}")
    omegas = {}
    for k in auto:
        if k == "posture":
            continue
        if k not in frames or not model.existFrame(frames[k]):
            raise RobotDefinitionError(f"'auto' applies to a frame of the robot (an orientation task) or to "
                                       f"posture; '{k}' is neither", key=f"gains.{k}")
        ids = [model.getFrameId(f) for f in contact_frames]
        omegas[k] = tipping_rate(model, q, model.getFrameId(frames[k]), ids) / (math.e * TILT_PER_IMPULSE)
        out[k] = omegas[k] ** 2
    if "posture" in auto:
        if len(omegas) != 1:
            raise RobotDefinitionError("'posture: auto' follows the frame entry set to 'auto': give exactly one "
                                       f"(e.g. torso: auto), found {len(omegas)}", key="gains.posture")
        out["posture"] = (POSTURE_RATIO * next(iter(omegas.values()))) ** 2
    return out
