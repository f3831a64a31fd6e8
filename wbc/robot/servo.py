"""Position-controlled actuators: the servo law and its gains (velocity mode's run loop).

A position-controlled joint's driver applies

    τ_i = sat(g_i(q) + k_p,i (q_cmd ⊖ q)_i + k_d,i (q̇_cmd,i − q̇_i)),   |τ_i| ≤ τ_max,i       (N·m, N)

on the actuated coordinates (both simulators: wbc.sim's per physics step, MuJoCo's position
actuators with the same gains). Gains (robot YAML ``position_gains:``): ``kp``/``kd`` per joint;
a joint not listed gets

    k_p = min(τ_max / e_sat, M_ii ω_b²),    k_d = 2 √(k_p M_ii)

(``saturation_error`` e_sat, default 0.01 rad or m: the servo reaches its torque limit at that
error; ``bandwidth`` ω_b, default 150 rad/s: the joint's closed-loop natural frequency on its own
reflected inertia M_ii (``crba`` at the default posture), which keeps ω_b h ≤ 0.15 at a 1 ms
physics step, where an explicit PD on a light wrist would otherwise diverge; k_d: critical
damping). g(q): the driver's gravity feed-forward on the actuated coordinates
(:func:`gravity_feedforward`, pinocchio's generalised gravity at the measured q, held over the
control period), as the drivers of TIAGo's and most arms' position controllers have; without
it a joint holding a load g_i would sag by g_i / k_p (1.7 cm at TIAGo's hand).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def servo_gains(robot) -> tuple[np.ndarray, np.ndarray]:
    """(k_p, k_d), nv each (N·m/rad or N/m, N·m·s/rad or N·s/m; 0 on unactuated coordinates and
    on coordinates without a finite torque limit unless given): module docstring.

    Args:
        robot: the :class:`~wbc.robot.model.RobotModel`.
    """
    spec = robot.position_gains or {}
    e_sat = float(spec.get("saturation_error", 0.01))
    wb = float(spec.get("bandwidth", 150.0))
    M = pin.crba(robot.model, robot.model.createData(), robot.q_default)
    kp, kd = np.zeros(robot.nv), np.zeros(robot.nv)
    tau = robot.tau_max
    for i in robot.actuated_idx:
        kp[i] = min(tau[i] / e_sat, M[i, i] * wb * wb) if np.isfinite(tau[i]) else M[i, i] * wb * wb
    for i, v in spec.get("kp", {}).items():
        kp[i] = v
    for i in robot.actuated_idx:
        kd[i] = 2.0 * np.sqrt(kp[i] * M[i, i])
    for i, v in spec.get("kd", {}).items():
        kd[i] = v
    return kp, kd


def gravity_feedforward(robot, data: pin.Data, q: np.ndarray) -> np.ndarray:
    """g(q) on the actuated coordinates, 0 on the others (nv; N·m, N).

    Args:
        robot: the :class:`~wbc.robot.model.RobotModel`.
        data: a pinocchio data of ``robot.model`` (not the controller's).
        q: the measured configuration (nq).
    """
    g = pin.computeGeneralizedGravity(robot.model, data, q).copy()
    g[robot.unactuated_idx] = 0.0
    return g


def servo_torque(model: pin.Model, q: np.ndarray, v: np.ndarray, q_cmd: np.ndarray, v_cmd: np.ndarray,
                 kp: np.ndarray, kd: np.ndarray, tau_ff: np.ndarray | None = None) -> np.ndarray:
    """τ_ff + k_p (q_cmd ⊖ q) + k_d (q̇_cmd − q̇) (nv; before saturation): the servo law above.

    Args:
        model: the pinocchio model (its ``difference`` on the configuration manifold).
        q: the measured configuration (nq).
        v: the measured velocity (nv).
        q_cmd: the commanded configuration (nq).
        v_cmd: the commanded velocity (nv).
        kp: stiffnesses (nv).
        kd: dampings (nv).
        tau_ff: the feed-forward torque (nv; the gravity's); None: none.
    """
    tau = kp * pin.difference(model, q, q_cmd) + kd * (v_cmd - v)
    return tau if tau_ff is None else tau + tau_ff
