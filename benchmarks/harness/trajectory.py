"""The bench trajectory: the references move every cycle, starting from rest.

The CoM sways sideways (±3 cm at 0.5 Hz) and the hand targets go round small vertical
circles (3 cm radius at 1 Hz, the two hands half a turn apart), with consistent position,
velocity and acceleration references; the phase's angular speed ramps up smoothly over
:data:`ONSET` so the motion starts at rest. The state is integrated from the controller's
q̈ as a double integrator at :data:`DT`. The bench's cases, its floor and the PlaCo peer
follow it, and so do the tests that check the solvers along it (``tests/bench/test_bench.py``,
``tests/controller/test_hot_path.py``, ``tests/solvers/test_dynamics.py``).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from wbc.robot.model import RobotModel
from wbc.stack import Stack
from wbc.tasks import CoM

DT = 1e-3                                    # s, the control period
ONSET = 0.2                                  # s: the speed ramps up from rest over this time
COM_AMPLITUDE, COM_FREQUENCY = 0.03, 0.5     # m, Hz
HAND_RADIUS, HAND_FREQUENCY = 0.03, 1.0      # m, Hz


def phase(t: float, w: float) -> tuple[float, float, float]:
    """Phase θ(t), θ̇, θ̈ of a motion whose angular speed ramps from 0 to ``w`` (rad/s)
    over :data:`ONSET` (θ̇ = w·smoothstep(t/ONSET)); then θ = w (t − ONSET/2)."""
    if t >= ONSET:
        return w * (t - ONSET / 2), w, 0.0
    x = max(t, 0.0) / ONSET
    return w * ONSET * (x**3 - x**4 / 2), w * (3 * x * x - 2 * x**3), w * (6 * x - 6 * x * x) / ONSET


def circle(t: float, radius: float, freq: float, phase0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Offset (m), velocity (m/s), acceleration (m/s²) on a vertical circle in the y-z
    plane of ``radius`` m at ``freq`` Hz, 0 at t = 0 (starting at rest, see :func:`phase`)."""
    th, dth, ddth = phase(t, 2 * np.pi * freq)
    a = th + phase0
    s, c = np.sin(a), np.cos(a)
    p = radius * np.array([0.0, s - np.sin(phase0), np.cos(phase0) - c])
    tang = np.array([0.0, c, s])
    v = radius * dth * tang
    acc = radius * ddth * tang + radius * dth * dth * np.array([0.0, -s, c])
    return p, v, acc


def sway(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sideways CoM offset (m), velocity, acceleration (starting at rest, see :func:`phase`)."""
    th, dth, ddth = phase(t, 2 * np.pi * COM_FREQUENCY)
    s, c = np.sin(th), np.cos(th)
    A = COM_AMPLITUDE
    return (np.array([0.0, A * s, 0.0]), np.array([0.0, A * c * dth, 0.0]),
            np.array([0.0, A * (c * ddth - s * dth * dth), 0.0]))


def moving_targets(robot: RobotModel, stack: Stack, circles: tuple[str, ...] = ("right_hand", "left_hand"),
                   radius: float = HAND_RADIUS) -> Callable[[float], None]:
    """A function ``set(t)`` that moves the stack's targets (robot.update done at the start
    state): the CoM task sways sideways, the Frame tasks named in ``circles`` go round small
    circles; position, velocity and acceleration references are consistent, and the motion
    starts from rest (speed ramped up over :data:`ONSET`)."""
    com = next((t for t in stack if isinstance(t, CoM)), None)
    com0 = robot.com.copy() if com is not None else None
    frames = []
    for i, name in enumerate(n for n in circles if n in stack):
        task = stack[name]
        frames.append((task, robot.frame_placement(robot.frame_id(task.frame)).copy(), i * np.pi))
    zero3 = np.zeros(3)

    def set_targets(t: float) -> None:
        if com is not None:
            p, v, a = sway(t)
            com.set_reference(com0 + p, v, a)
        for task, M0, phase0 in frames:
            p, v, a = circle(t, radius, HAND_FREQUENCY, phase0)
            task.set_reference(pin.SE3(M0.rotation, M0.translation + p), np.concatenate([v, zero3]),
                               np.concatenate([a, zero3]))

    return set_targets


def timed_cycles(ctrl, robot: RobotModel, targets: Callable[[float], None], cycles: int, warmup: int = 200,
                 on_warm: Callable[[], None] | None = None) -> list[int]:
    """Run ``ctrl`` in closed loop on its own q̈ (semi-implicit Euler at :data:`DT`) along
    ``targets`` from the robot's default posture at rest, for ``warmup`` then ``cycles``
    cycles; ``on_warm`` is called once the warm-up is over. Returns each measured cycle's
    ``Controller.solve`` thread time (ns)."""
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    total = []
    for k in range(warmup + cycles):
        targets(k * DT)
        if k == warmup and on_warm is not None:
            on_warm()
        t0 = time.thread_time_ns()
        sol = ctrl.solve(q, v)
        if k >= warmup:
            total.append(time.thread_time_ns() - t0)
        v = v + sol.qdd * DT
        q = pin.integrate(robot.model, q, v * DT)
    return total
