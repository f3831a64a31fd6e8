"""The run-time walker: each control cycle it advances the walk's phase, replans the CoM
(ZMP preview control from the measured CoM and DCM, every ``replan_period`` s), and sets the
references of the stack's tasks and its contacts.

Per cycle (:meth:`Walker.update`, before the solve, at time t):

- CoM task: (c, ċ, c̈) of :class:`~wbc.locomotion.preview.ZmpPreview` in x, y (replanned at a
  fixed rate from the measured CoM c and velocity ċ, i.e. from the measured DCM
  ξ = c + ċ/ω: the preview's state feedback is the DCM feedback), its height held at the
  start's. While a foot swings, the swing leg's angular momentum about the CoM is added
  (:meth:`Walker.swing_momentum_terms`, the multi-body ZMP: the ZMP stays on the LIPM's; the
  previous cycle's q̈ gives its rate).
- Contacts, inside each double support through the controller's force ramps
  (:mod:`wbc.controller.force_ramps`): ``ramp`` s before a single support the swing foot's
  contact is released (its force ramped to 0 N) and a swing Frame task added, holding the
  foot; at the single support's start the foot follows a quintic
  (:class:`~wbc.locomotion.swing.SwingTrajectory`) to its footstep. Touch-down: the
  measured normal force on the swing foot over ``touchdown_force`` × m g after half the swing
  (early), or at the swing's end (on time); without it the target keeps descending at
  ``descent_speed`` for up to ``late_max`` s while the plan waits (late: the remaining phases
  are delayed by as much); after that the walk stops, "missed touchdown". At touch-down the
  contact task is put back (its force ramped up from 0 N over ``ramp`` s) and the swing task
  removed.
- Orientation tasks (the pelvis, the torso): their yaw follows the mean yaw of the feet,
  moving with the swing foot's.

The walker holds the plan (:class:`~wbc.locomotion.plan.WalkPlan`); :meth:`Walker.command`
and :meth:`Walker.stop` change its future at run time (a command beyond the limits clipped,
with a warning).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from wbc.locomotion.footsteps import Footstep, StepLimits, from_command, wrap
from wbc.locomotion.plan import Command, WalkPlan
from wbc.locomotion.preview import ZmpPreview
from wbc.locomotion.swing import SwingTrajectory, quintic
from wbc.locomotion.timing import Timing
from wbc.tasks.com import CoM
from wbc.tasks.frame import Frame

SIDES = ("left", "right")


@dataclass
class WalkSpec:
    """A ``walk:`` section (:mod:`wbc.scenario.walk_section`): either ``footsteps`` (poses
    relative to the start's walking frame: the feet's mid-point and mean yaw; m, m, rad) or a
    ``command``; ``timing``; ``step_height`` (m, the swing apex above the ground); ``limits``;
    ``start`` (s, the walk's first double support begins); ``contacts``: side -> the robot's
    contact surface; ``changes``: run-time changes, (time s, Command or None = stop), sorted;
    ``swing_kp`` (1/s²); ``replan_period`` and ``horizon`` (s) of the preview;
    ``touchdown_force`` (fraction of m g), ``late_max`` (s), ``descent_speed`` (m/s),
    ``touchdown_depth`` (m: the swing aims this far below the ground, so that a foot lagging
    its spline by as much still lands on the clock); ``horizontal``: the fraction of the swing
    in which the foot moves horizontally (it comes down vertically after it);
    ``swing_momentum``: the CoM's reference and its replanning take the swing leg's angular
    momentum into account (:meth:`Walker.swing_momentum_terms`), so that the ZMP stays on the
    LIPM's."""

    footsteps: list[Footstep] | None = None
    command: Command | None = None
    timing: Timing = field(default_factory=Timing)
    step_height: float = 0.05
    limits: StepLimits = field(default_factory=StepLimits)
    start: float = 0.0
    contacts: dict[str, str] = field(default_factory=lambda: {"left": "left_foot", "right": "right_foot"})
    changes: list[tuple[float, Command | None]] = field(default_factory=list)
    swing_kp: float = 400.0
    replan_period: float = 0.01
    horizon: float = 1.6
    touchdown_force: float = 0.05
    late_max: float = 0.15
    descent_speed: float = 0.1
    touchdown_depth: float = 0.002
    horizontal: float = 0.8
    swing_momentum: bool = True


def pose2d(M: pin.SE3) -> tuple[float, float, float]:
    """(x, y, yaw) of a placement (m, m, rad; yaw of its x axis about the world z)."""
    R = M.rotation
    return float(M.translation[0]), float(M.translation[1]), math.atan2(R[1, 0], R[0, 0])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class Walker:
    """The walk of ``spec`` for the stack's tasks (module docstring).

    Args:
        spec: the walk (:class:`WalkSpec`).
        robot: the controller's robot (its model; the walker reads the measured state itself).
        stack: the controller's stack: one CoM task, a contact task per foot of
            ``spec.contacts``, and any orientation-only Frame tasks (pelvis, torso).
        ctrl: the controller (``release_contact``, ``make_contact``).
        dt: the control period (s).
    """

    def __init__(self, spec: WalkSpec, robot, stack, ctrl, dt: float) -> None:
        self.spec, self.robot, self.stack, self.ctrl, self.dt = spec, robot, stack, ctrl, dt
        self.model = robot.model
        self.data = robot.model.createData()      # the walker's own: the controller's stays as it is
        self.com_task = next(t for t in stack if isinstance(t, CoM))
        self.com_level = stack.level_of(self.com_task.name)
        self.contact_task = {side: next(t for t in stack.contacts() if t.contact == spec.contacts[side])
                             for side in SIDES}
        self.contact_level = {side: stack.level_of(t.name) for side, t in self.contact_task.items()}
        self.sole_fid = {side: robot.frame_id(robot.contact(spec.contacts[side]).frame) for side in SIDES}
        self.orient = [t for t in stack if isinstance(t, Frame) and list(t.axes) == [3, 4, 5]]
        self.plan: WalkPlan | None = None
        self.preview: ZmpPreview | None = None
        self.i = 0                 # next step to take
        self.state = "wait"        # of step i: wait, release, swing, late
        self.delay = 0.0           # s the plan waits for a late landing
        self.swing: SwingTrajectory | None = None
        self.swing_task: Frame | None = None
        self.t_swing = 0.0
        self.stopped: str | None = None
        self.touchdowns: list[dict] = []
        self.ground_z = 0.0
        self.changes = list(spec.changes)
        self.warnings: list[str] = []
        self.touchdown_fz = spec.touchdown_force * robot.weight     # N, the landing threshold
        self._q = robot.q_default                 # the last measured configuration
        # the swing leg's momentum: per foot, the model reduced to the root joint and that leg
        # (every other joint locked: the RNEA's joint force at the hip depends only on the leg's
        # bodies and the root's motion), without gravity; the indices of its q and q̇ in the robot's
        self.leg_root = {side: _leg_root(self.model, self.model.frames[fid].parentJoint)
                         for side, fid in self.sole_fid.items()}
        self.leg_joints = {side: list(self.model.subtrees[j]) for side, j in self.leg_root.items()}
        self._leg = {side: _leg_model(self.model, self.leg_root[side], self.leg_joints[side], robot.q_default)
                     for side in SIDES}
        self.mass = float(robot.mass)
        self._turn: float | None = None   # rad, the orientation tasks' yaw last set
        self._orient_key: tuple | None = None   # (step, swinging) of the feet's yaws below
        self._yaws: dict[str, float] = {}
        self._dyaw = 0.0                  # rad, the swing foot's turn in this step
        self._twist = np.zeros(6)         # the swing task's twist and acceleration references
        self._twist_acc = np.zeros(6)
        self.ell = np.zeros(2)            # m/s, the swing leg's share of the CoM velocity (x, y)
        self.ell_dot = np.zeros(2)        # m/s², its rate
        self.ell_int = np.zeros(2)        # m, its integral since the last replan

    # ---------------------------------------------------------------- start
    def begin(self, t: float, q: np.ndarray, v: np.ndarray) -> None:
        """Plan the walk from the measured state at ``t``."""
        m, d = self.model, self.data
        pin.forwardKinematics(m, d, q, v)
        pin.updateFramePlacements(m, d)
        c = pin.centerOfMass(m, d, q, v)
        start = {}
        for side in SIDES:
            x, y, yaw = pose2d(d.oMf[self.sole_fid[side]])
            start[side] = Footstep(side, x, y, yaw)
        self.ground_z = float(np.mean([d.oMf[f].translation[2] for f in self.sole_fid.values()]))
        self.feet_rot0 = {side: d.oMf[self.sole_fid[side]].rotation.copy() for side in SIDES}
        self.start_feet = start
        spec = self.spec
        if spec.footsteps is not None:
            steps = [_from_frame(s, start) for s in spec.footsteps]
        else:
            cmd = spec.command
            steps = from_command(start, (cmd.vx, cmd.vy, cmd.omega), spec.timing.single + spec.timing.double,
                                 cmd.steps, spec.limits) if cmd is not None else []
        self.plan = WalkPlan(start, steps, spec.timing, spec.start, spec.limits)
        self.z_com = float(c[2])
        z_c = self.z_com - self.ground_z
        self.preview = ZmpPreview(z_c, self._zmp_ahead, spec.replan_period, spec.horizon, g=self.robot.gravity)
        self.preview.reset(c[:2], d.vcom[0][:2], t)
        self.yaw0 = _mean_yaw(start)
        self.orient_rot0 = {}
        for task in self.orient:
            M = d.oMf[self.robot.frame_id(task.frame)]
            self.orient_rot0[task.name] = M.rotation.copy()
        self._turn = None
        self._orient_key = None

    def _zmp_ahead(self, t: float, dt: float, n: int, out: np.ndarray) -> np.ndarray:
        assert self.plan is not None
        return self.plan.table.sample(t - self.delay, dt, n, out)

    # ---------------------------------------------------------------- changes
    def command(self, t: float, cmd: Command | None) -> None:
        """From ``t`` on walk ``cmd`` (None: stop, the feet side by side), from the first step
        not yet begun; a command beyond the limits is clipped to them, with a warning."""
        assert self.plan is not None
        n = self.i + (1 if self.state != "wait" else 0)
        if cmd is not None:
            try:
                from_command(self.plan.start, (cmd.vx, cmd.vy, cmd.omega), self.spec.timing.single + self.spec.timing.double,
                             1, self.spec.limits)
            except Exception as exc:        # a ConfigError naming the component beyond its limit
                msg = f"walk command at t = {t:g} s clipped to the limits: {exc}"
                self.warnings.append(msg)
                warnings.warn(msg, stacklevel=2)
        self.plan.replace_from(n, t - self.delay, cmd, clip=True)

    # ---------------------------------------------------------------- cycle
    def update(self, t: float, q: np.ndarray, v: np.ndarray, fz: dict[str, float],
               qdd: np.ndarray | None = None) -> None:
        """One control cycle at ``t`` s: measured ``q``, ``v`` and the normal force (N) on each
        foot ``fz`` (side -> N); ``qdd``: the previous cycle's joint accelerations (None: not
        known; no swing correction); sets the tasks' references and switches the contacts."""
        if self.plan is None:
            self.begin(t, q, v)
        assert self.plan is not None and self.preview is not None
        while self.changes and self.changes[0][0] <= t + 1e-9:
            self.command(t, self.changes.pop(0)[1])
        if self.spec.swing_momentum and qdd is not None and self.state in ("swing", "late"):
            self.swing_momentum_terms(q, v, qdd, self.plan.steps[self.i].side)
        else:
            self.ell[:] = 0.0
            self.ell_dot[:] = 0.0
        if self.preview.due(t):         # the measured CoM and velocity: only a replan reads them
            c = pin.centerOfMass(self.model, self.data, q, v)
            self.preview.replan(c[:2], self.data.vcom[0][:2] - self.ell, t)
            self.ell_int[:] = 0.0
        else:
            self.ell_int += self.ell * self.dt
        self._q = q
        self._contacts(t, fz)
        pc, vc, ac = self.preview.sample(t)
        self.com_task.set_reference(np.array([pc[0] + self.ell_int[0], pc[1] + self.ell_int[1], self.z_com]),
                                    np.array([vc[0] + self.ell[0], vc[1] + self.ell[1], 0.0]),
                                    np.array([ac[0] + self.ell_dot[0], ac[1] + self.ell_dot[1], 0.0]))
        self._orientation(t)

    def swing_momentum_terms(self, q: np.ndarray, v: np.ndarray, qdd: np.ndarray, side: str) -> None:
        """The swing leg's share ℓ of the CoM velocity and its rate ℓ̇ (xy; m/s, m/s²).

        With L the ``side`` leg's angular momentum about the CoM c (N·m·s; the RNEA without
        gravity, the leg's weight being in the CoM's, gives at the hip the rate of the leg's
        spatial momentum at (q, q̇, q̈) and the momentum itself at (q, 0, q̇)), the ZMP of the
        whole robot is p = c − z_c c̈/g + (−L̇_y, L̇_x)/(m g) (the multi-body ZMP).
        With ℓ = (−L_y, L_x)/(m z_c) and u = ċ − ℓ the LIPM holds in (c, u):

            u̇ = ω² (c − p),   ċ = u + ℓ,

        so the preview plans u (replanned from the measured ċ − ℓ) and the CoM task follows
        c̈ = u̇ + ℓ̇, ċ = u + ℓ: the ZMP stays on the LIPM's while the leg swings. The LIPM alone
        leaves this momentum out; on a robot whose legs are a large part of its mass (the
        G1's: 22 %) a fast swing then asks more CoP than the stance sole has. The previous
        cycle's q̈ stands for this one's (the swing foot's reference is smooth)."""
        m, d, root, iq, iv, zero = self._leg[side]
        qs, vs = q[iq], v[iv]
        pin.rnea(m, d, qs, vs, qdd[iv])
        M = d.liMi[root]
        parent = m.parents[root]
        if parent > 0:                  # the root joint's liMi is its world placement
            M = d.liMi[parent] * M
        F = M.act(d.f[root])            # the leg's rate of momentum (world axes, at the origin)
        # the RNEA with zero velocity and q̈ = q̇: each body's "acceleration" is its velocity,
        # so the hip's joint force is the leg's momentum
        pin.rnea(m, d, qs, zero, vs)
        H = M.act(d.f[root])
        cx, cy, cz = self.robot.com
        f, n = F.linear, F.angular
        h, a = H.linear, H.angular
        k = 1.0 / (self.mass * (self.z_com - self.ground_z))
        # L = a − c × h, L̇ = n − c × f (about the CoM), x and y components
        self.ell[0] = -(a[1] - (cz * h[0] - cx * h[2])) * k
        self.ell[1] = (a[0] - (cy * h[2] - cz * h[1])) * k
        self.ell_dot[0] = -(n[1] - (cz * f[0] - cx * f[2])) * k
        self.ell_dot[1] = (n[0] - (cy * f[2] - cz * f[1])) * k

    def _contacts(self, t: float, fz: dict[str, float]) -> None:
        plan = self.plan
        assert plan is not None
        tau = t - self.delay
        if self.i >= len(plan.steps):
            return
        step = plan.steps[self.i]
        ts, te = plan.single[self.i]
        ramp = self.spec.timing.ramp
        side = step.side
        if self.state == "wait" and tau >= ts - ramp - 1e-9:
            self.ctrl.release_contact(self.contact_task[side].name, ramp)
            fid = self.sole_fid[side]
            pin.forwardKinematics(self.model, self.data, self._q)
            pin.updateFramePlacement(self.model, self.data, fid)
            here = self.data.oMf[fid].copy()
            task = Frame(self.robot.model.frames[fid].name, kp=self.spec.swing_kp, name=f"{side}_swing", target=here)
            task.bind(self.robot)
            self.stack.add(task, self.com_level)
            self.swing_task, self.state = task, "release"
        if self.state == "release" and tau >= ts - 1e-9 and self.swing_task is not None:
            M = self.swing_task.target
            assert M is not None
            x, y, yaw = pose2d(M)
            goal = [step.x, step.y, self.ground_z - self.spec.touchdown_depth, yaw + wrap(step.yaw - yaw)]
            self.swing = SwingTrajectory([x, y, M.translation[2], yaw], goal, te - ts, self.spec.step_height,
                                         self.spec.horizontal)
            self.swing_rot = M.rotation.copy()
            self.swing_yaw0 = yaw
            self.t_swing, self.state = ts, "swing"
        if self.state in ("swing", "late") and self.swing is not None:
            self._swing(t, tau - self.t_swing, side, self.swing, fz[side])

    def _swing(self, t: float, s: float, side: str, swing: SwingTrajectory, fz: float) -> None:
        """The swing foot ``s`` s after lift-off: its reference, or the touch-down (early: the
        foot's force after half the swing; on time; late: descending while the plan waits)."""
        if fz > self.touchdown_fz and s >= 0.5 * swing.T:
            self._touchdown(t, side, early=s < swing.T - 1e-9)
            return
        if s < swing.T - 1e-9:
            self._swing_reference(*swing.sample(s))
            return
        # the clock's end without contact: keep descending while the plan waits
        if self.state == "swing":
            self.state, self.t_late = "late", t
        late = t - self.t_late
        if late > self.spec.late_max:
            self.stopped = f"missed touchdown: the {side} foot found no ground {late:.3f} s after its swing"
            return
        self.delay += self.dt
        p, vel, acc = swing.sample(swing.T)
        p[2] -= self.spec.descent_speed * late
        vel[2] = -self.spec.descent_speed
        self._swing_reference(p, vel, acc)

    def _swing_reference(self, p: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> None:
        turn = p[3] - self.swing_yaw0
        R = rot_z(turn) @ self.swing_rot if turn != 0.0 else self.swing_rot
        task = self.swing_task
        assert task is not None
        tw, ta = self._twist, self._twist_acc       # (linear, angular z) filled, the rest 0
        tw[:3], tw[5] = vel[:3], vel[3]
        ta[:3], ta[5] = acc[:3], acc[3]
        task.set_reference(pin.SE3(R, p[:3].copy()), tw.copy(), ta.copy())

    def _touchdown(self, t: float, side: str, early: bool) -> None:
        task = self.contact_task[side]
        self.ctrl.make_contact(task, level=min(self.contact_level[side], len(self.stack.levels)),
                               duration=self.spec.timing.ramp)
        assert self.swing_task is not None
        self.stack.remove(self.swing_task.name)
        late = self.state == "late"
        self.touchdowns.append({"time": t, "side": side, "early": early, "late": late, "delay": self.delay})
        self.swing_task, self.swing = None, None
        self.i += 1
        self.state = "wait"

    def _orientation(self, t: float) -> None:
        """The orientation tasks' yaw: the mean of the feet's (the swing foot's as it moves)."""
        if not self.orient:
            return
        plan = self.plan
        assert plan is not None
        swinging = self.state in ("swing", "late") and self.swing is not None
        if (self.i, swinging) != self._orient_key:      # a phase change: the feet's yaws anew
            self._orient_key = (self.i, swinging)
            feet = plan.feet_after(self.i)
            self._yaws = {s: feet[s].yaw for s in SIDES}
            step = plan.steps[self.i] if swinging else None
            self._dyaw = wrap(step.yaw - self._yaws[step.side]) if step is not None else 0.0
        elif self._dyaw == 0.0:         # no foot turning: the targets hold (a straight walk)
            return
        yaws = dict(self._yaws)
        if swinging and self._dyaw != 0.0:
            assert self.swing is not None
            side = plan.steps[self.i].side
            s = min((t - self.delay - self.t_swing) / self.swing.T, 1.0)
            yaws[side] = yaws[side] + self._dyaw * quintic(s)[0]
        yaw = yaws["left"] + 0.5 * wrap(yaws["right"] - yaws["left"])
        turn = wrap(yaw - self.yaw0)
        if turn == self._turn:          # the targets hold already (a straight walk: every cycle)
            return
        self._turn = turn
        Rz = rot_z(turn)
        for task in self.orient:
            task.target = pin.SE3(Rz @ self.orient_rot0[task.name], np.zeros(3))

    # ---------------------------------------------------------------- status
    @property
    def done(self) -> bool:
        """Every step taken and the plan's last double support over."""
        return self.plan is not None and self.i >= len(self.plan.steps)


def _leg_model(model, root: int, leg: list[int], q_ref: np.ndarray) -> tuple:
    """(model, data, the leg root's joint index, q indices, q̇ indices, zero q̇) of ``model``
    reduced to its root joint and the joints ``leg`` (the subtree of ``root``), without
    gravity."""
    keep = {1, *leg} if model.parents[root] == 1 else set(leg)
    lock = [j for j in range(1, model.njoints) if j not in keep]
    red = pin.buildReducedModel(model, lock, q_ref)
    red.gravity = pin.Motion.Zero()
    iq: list[int] = []
    iv: list[int] = []
    for j in sorted(keep):
        iq += range(model.idx_qs[j], model.idx_qs[j] + model.nqs[j])
        iv += range(model.idx_vs[j], model.idx_vs[j] + model.nvs[j])
    return (red, red.createData(), red.getJointId(model.names[root]), np.array(iq), np.array(iv),
            np.zeros(red.nv))


def _leg_root(model, joint: int) -> int:
    """The ancestor of ``joint`` (a foot's) whose parent is the root joint (joint 1, the
    free flyer): the hip of the foot's leg."""
    while model.parents[joint] > 1:
        joint = model.parents[joint]
    return joint


def _mean_yaw(feet: dict[str, Footstep]) -> float:
    return wrap(feet["left"].yaw + 0.5 * wrap(feet["right"].yaw - feet["left"].yaw))


def _from_frame(step: Footstep, start: dict[str, Footstep]) -> Footstep:
    """A footstep given in the start's walking frame (the feet's mid-point, their mean yaw),
    in the world."""
    mid = (start["left"].xy + start["right"].xy) / 2
    yaw = _mean_yaw(start)
    c, s = math.cos(yaw), math.sin(yaw)
    return Footstep(step.side, float(mid[0] + c * step.x - s * step.y), float(mid[1] + s * step.x + c * step.y),
                    wrap(yaw + step.yaw))
