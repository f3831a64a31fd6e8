"""The controller's model of the joints' damping and dry friction (robot YAML ``compensate:``).

    compensate: {damping: true, friction: true, friction_velocity: 0.01}

With it, the dynamics model the controller solves with (:attr:`wbc.robot.model.RobotModel.h`, so
the floating-base rows, the torque-limit rows and τ = S(M q̈ + h − J_fᵀ f) of (5.26) alike) is

    h_eff(q, q̇) = C(q, q̇) q̇ + g(q) + D q̇ + F σ(q̇),   σ(q̇)_i = tanh(q̇_i / v_s),

D and F the URDF's ``<dynamics damping friction>`` (pinocchio's ``model.damping`` in N·m·s/rad
or N·s/m, ``model.friction`` in N·m or N), each term only if asked. The commanded torque then
adds the torque the joints' damping and friction take away, for the measured q̇.

The sign is smoothed: sgn jumps by 2F where q̇ crosses 0, and a measured velocity that
jitters about 0 (noise, a joint that sticks) would make the command chatter by ±F; tanh is
odd, smooth and bounded by 1, with slope 1/v_s at 0, so the compensation fades in over
|q̇| ≲ v_s (76 % of F at v_s, 99.5 % at 3 v_s). ``friction_velocity`` v_s (rad/s or m/s,
default 0.01) trades the friction left uncompensated at slow motion against that chatter.
A joint at rest is not compensated (σ(0) = 0): its static friction holds it as the
simulator's (or the real joint's) does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: default v_s (rad/s or m/s) of the smoothed sign
FRICTION_VELOCITY = 0.01


@dataclass(frozen=True)
class JointCompensation:
    """D q̇ + F tanh(q̇ / v_s) (module docstring): ``damping`` D and ``friction`` F per dof
    (nv; zeros where not compensated), ``velocity`` v_s > 0."""

    damping: np.ndarray
    friction: np.ndarray
    velocity: float = FRICTION_VELOCITY

    @classmethod
    def of_model(cls, model, damping: bool, friction: bool,
                 friction_velocity: float = FRICTION_VELOCITY) -> JointCompensation | None:
        """The compensation of the terms asked, with the model's URDF values; None when
        nothing is asked or the model has none of them (no cost per cycle then)."""
        d = np.array(model.damping, float) if damping else np.zeros(model.nv)
        f = np.array(model.friction, float) if friction else np.zeros(model.nv)
        if not (d.any() or f.any()):
            return None
        return cls(d, f, float(friction_velocity))

    def torque(self, v: np.ndarray) -> np.ndarray:
        """D q̇ + F tanh(q̇ / v_s) (nv, N·m or N) at the velocity v (nv, rad/s or m/s)."""
        return self.damping * v + self.friction * np.tanh(v / self.velocity)
