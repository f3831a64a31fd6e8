"""The stacks the benchmark times and the tests share, each written once.

- :func:`talos_stack`: Talos, hard constraints (joint and torque limits, two foot
  contacts) / CoM / both hands / posture, and by default a fifth level regularising the
  contact forces: the full stack of the bench (5 levels: 50 variables x = (q̈, f), nv 38
  + 2 × 6 wrench components). The property tests (``tests/helpers/stacks.py``) take the same
  stack without the fifth level, with the left hand at weight 0.5 inside its level.
- :func:`tiago_stack`: TIAGo, limits / hand position / posture (the bench) or with a torso
  orientation level between hand and posture (the tests).
- :func:`talos_levels_stack`: the levels sweep, ten Talos task groups over 1 to 10 levels.
- :func:`chain_robot`, :func:`chain_stack`: the nv sweep, a serial chain of n revolute joints.

Gains in 1/s² (kp; kd critical by default), weights unitless, forces in N.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.robot.model import RobotModel
from wbc.stack import Stack
from wbc.tasks import CoM, Contact, ContactWrench, Frame, JointLimits, Posture, TorqueLimits

#: Talos's weight (N) as loaded by robots/talos.yaml (mass 90.27 kg × 9.81 m/s²), for the
#: contact-force regularisation of the full stack
TALOS_WEIGHT = 885.5


def talos_stack(*, regularise: bool = True, left_hand_weight: float = 1.0, bilateral: bool = False,
                limits: bool = True, torque_limits: bool = True, cop_margin: float | None = None) -> Stack:
    """The Talos stack: level 0 the hard constraints (joint limits if ``limits``, torque
    limits if ``torque_limits``, the two foot contacts, ``bilateral`` or unilateral with
    f_z ≥ 0) / CoM (kp 100) / both hands (kp 50, the left one at ``left_hand_weight``) /
    posture (kp 10), and with ``regularise`` (the bench's full stack, 5 levels) the
    contact forces regularised: each sole's wrench towards half the weight, the 6
    internal-force directions nothing above decides. ``cop_margin``: the contacts' (default
    :class:`~wbc.tasks.Contact`'s, 20 % of the sole; 0 keeps the CoP in the whole sole, as
    PlaCo's planar contacts do).

    (An earlier bench stack had a torso-orientation level in place of the regularisation:
    on the bench trajectory it left a pelvis-yaw mode to drift until joints ran at their
    velocity limits, which is neither what the performance issue specifies nor a motion a
    robot would make.)"""
    level0 = [JointLimits()] if limits else []
    if torque_limits:
        level0.append(TorqueLimits())
    opts = {} if cop_margin is None else {"cop_margin": cop_margin}
    level0 += [Contact("left_foot", bilateral=bilateral, **opts), Contact("right_foot", bilateral=bilateral, **opts)]
    levels = [
        level0,
        [CoM(kp=100.0)],
        [Frame("right_hand", kp=50.0), Frame("left_hand", kp=50.0, weight=left_hand_weight)],
        [Posture(kp=10.0)],
    ]
    if regularise:
        half = [0.0, 0.0, 0.5 * TALOS_WEIGHT, 0.0, 0.0, 0.0]
        levels.append([ContactWrench("left_foot_contact", target=half),
                       ContactWrench("right_foot_contact", target=half)])
    return Stack(levels)


def tiago_stack(*, torso: bool = False, limits: bool = True) -> Stack:
    """TIAGo: joint and torque limits (if ``limits``) / hand position (kp 50) / torso
    orientation (kp 20, if ``torso``) / posture (kp 10); the differential drive is added
    by the controller."""
    levels = [[JointLimits(), TorqueLimits()]] if limits else []
    levels.append([Frame("hand", kp=50.0, mask="position")])
    if torso:
        levels.append([Frame("torso", kp=20.0, mask="orientation")])
    levels.append([Posture(kp=10.0)])
    return Stack(levels)


def talos_task_groups() -> list[list]:
    """Ten groups of Talos tasks, in priority order, for the levels sweep."""
    return [
        [JointLimits(), TorqueLimits(), Contact("left_foot"), Contact("right_foot")],
        [CoM(kp=100.0)],
        [Frame("right_hand", kp=50.0)],
        [Frame("left_hand", kp=50.0)],
        [Frame("torso", kp=20.0, mask="orientation")],
        [Frame("head", kp=20.0, mask="orientation")],
        [Frame("right_elbow", kp=20.0, mask="position")],
        [Frame("left_elbow", kp=20.0, mask="position")],
        [Frame("base", kp=20.0, mask="orientation")],
        [Posture(kp=10.0)],
    ]


def talos_levels_stack(n_levels: int) -> Stack:
    """The same ten task groups merged into ``n_levels`` consecutive levels (1 to 10)."""
    groups = talos_task_groups()
    chunks = np.array_split(np.arange(len(groups)), n_levels)
    return Stack([[t for g in chunk for t in groups[g]] for chunk in chunks])


def chain_stack() -> Stack:
    """The simple stack of the nv sweep: joint limits / tip / middle link / posture."""
    return Stack([
        [JointLimits()],
        [Frame("tip", kp=50.0, mask="position")],
        [Frame("mid", kp=50.0, mask="position")],
        [Posture(kp=10.0)],
    ])


def chain_robot(n: int, length: float = 1.0, mass: float = 10.0) -> RobotModel:
    """A fixed-base serial chain of ``n`` revolute joints (axes y, x, z in turn), built with
    pinocchio, ``length`` m and ``mass`` kg in all; frames ``tip`` (end) and ``mid``."""
    m = pin.Model()
    m.name = f"chain{n}"
    seg, mi = length / n, mass / n
    axes = (pin.JointModelRY, pin.JointModelRX, pin.JointModelRZ)
    parent = 0
    for i in range(n):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, seg if i else 0.0]))
        parent = m.addJoint(parent, axes[i % 3](), placement, f"joint_{i}", np.array([200.0]),
                            np.array([5.0]), np.array([-2.5]), np.array([2.5]))
        inertia = pin.Inertia(mi, np.array([0.0, 0.0, seg / 2]),
                              np.diag([mi * seg**2 / 12 + 1e-6, mi * seg**2 / 12 + 1e-6, 1e-6]))
        m.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    m.addFrame(pin.Frame("tip", parent, pin.SE3(np.eye(3), np.array([0.0, 0.0, seg])), pin.FrameType.OP_FRAME))
    m.addFrame(pin.Frame("mid", max(1, n // 2), pin.SE3(np.eye(3), np.array([0.0, 0.0, seg])),
                         pin.FrameType.OP_FRAME))
    q0 = np.random.default_rng(n).uniform(-0.3, 0.3, n)
    return RobotModel(name=f"chain{n}", model=m, root="fixed", actuated_root=False,
                      frames={"tip": "tip", "mid": "mid"}, contacts={}, q_default=q0,
                      q_min=m.lowerPositionLimit.copy(), q_max=m.upperPositionLimit.copy(),
                      v_max=m.velocityLimit.copy(), tau_max=m.effortLimit.copy())
