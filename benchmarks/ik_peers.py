"""Velocity-level IK, wbc against its peers on one problem, interleaved in one process (issue #23).

Problem (Talos, talos_reduced.urdf, 38 velocity coordinates, from wbc's default posture q0):
both soles held at their placements (6-D each), the CoM to its start + (0, 0, −0.03) m, the
right gripper's position to its start + (0.10, −0.05, 0.10) m, the posture towards q0.

- wbc: ``Controller(robot, stack, mode="velocity", solver="hqp", gain=1/dt)``, levels
  [feet, joint limits] / [CoM] / [hand] / [posture] (strict), one solve = ``update_kinematics`` + rows + hqp;
- PlaCo 0.10.2 ``KinematicsSolver``: feet and CoM hard, hand soft (weight 1), posture soft
  (1e-4); one solve = ``update_kinematics`` + ``solve(False)`` (its own kinematics update);
- pink 4.4.0 ``solve_ik`` (daqp): feet as ``constraints`` (hard), CoM cost 1, hand cost 1,
  posture cost 1e-2; one solve = ``Configuration.update(q)`` + ``solve_ik``;
- mink 1.3.0 ``solve_ik`` (daqp) on the MuJoCo compilation of the same URDF (wbc's, the
  default environment: mink needs mujoco): feet as ``constraints`` (hard; as costs of 1e4
  daqp fails on the QP), CoM 1, hand 1, posture 1e-2 (see
  :class:`MinkIK` for the fused links); one solve = ``Configuration.update`` + ``solve_ik``.

Timed: each solver's kinematics update and solve at q0 (``timed``), nothing of this script's
own conversions; the convergence runs (``solve``) convert configurations between orders.

Measured per solver, interleaved (each round runs every solver once at the same state):
``time per solve`` (median over ROUNDS solves at q0, ms), ``iterations`` (full steps
q ← q ⊕ Δq from q0 until ‖Δq‖ < 1e-9, at most 200; the unreachable case: until three steps
in a row are, at most 600, as wbc's step check may hold one step and not the next), and the
converged pose's errors (hand, CoM, feet drift in m; posture ‖q0 ⊖ q‖ over the joints in rad).

Unreachable case (``--unreachable``): the right gripper's target at the centre of the torso's
convex hull (``torso_2_link_0``'s bounding box centre): wbc with ``collision_avoidance`` at level 0 (self
pairs of wbc/data/robots/talos.collisions.yaml, d_i 5 cm, d_s 1 cm), PlaCo with its
self-collision constraint, pink with ``SelfCollisionBarrier`` (d_min 1 cm): the smallest
distance between the right arm's links and the torso each keeps while iterating (wbc's
convex-hull distances, the same measure for all). The torso (``torso_2_link``) is held still
in all three (6-D, hard like the feet) and the CoM at its start: otherwise the target is uncovered
by turning the torso away and is reached (wbc did, to 7e-5 m).

pink, PlaCo: the peer environment (Python 3.11, pinocchio 3.8); mink: the default one
(Python 3.13, pinocchio 4.1, MuJoCo). wbc runs in both, so each process gives ratios to wbc
measured interleaved in that process.

    PYTHONPATH=. python benchmarks/ik_peers.py [--rounds N] [--unreachable] [--clock wall|cpu]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np
import pinocchio as pin

from wbc import Controller, Stack
from wbc.robot.loader import load_robot
from wbc.tasks import CollisionAvoidance, CoM, Contact, Frame, JointLimits, Posture

HAND = "gripper_right_base_link"
SOLES = ("left_sole_link", "right_sole_link")
TORSO = "torso_2_link"
DT = 1.0           # s: one full Gauss–Newton step per solve (velocity limits × DT do not bind)
HAND_OFFSET = np.array([0.10, -0.05, 0.10])
COM_OFFSET = np.array([0.0, 0.0, -0.03])
MAX_ITER = 200
#: the unreachable case's step: the fraction of each task's error asked per solve (wbc's gain·DT,
#: pink's task gains); PlaCo's KinematicsSolver takes full steps (no gain to set)
STEP = 0.1


class Problem:
    """The IK problem's targets at q0 and its error measures (pinocchio, wbc's model)."""

    def __init__(self, robot, unreachable: bool = False) -> None:
        self.robot, self.model = robot, robot.model
        self.data = self.model.createData()
        self.q0 = robot.q_default.copy()
        m, d = self.model, self.data
        pin.framesForwardKinematics(m, d, self.q0)
        self.feet = {f: d.oMf[m.getFrameId(f)].copy() for f in SOLES}
        self.com = pin.centerOfMass(m, d, self.q0).copy() + (0.0 if unreachable else COM_OFFSET)
        #: the unreachable case holds the torso still (6-D, hard like the feet): the target inside
        #: its hull cannot be uncovered by leaning or turning it away
        self.torso = d.oMf[m.getFrameId(TORSO)].copy() if unreachable else None
        if unreachable:               # the centre of the torso's convex hull (its box's centre)
            from wbc.collision.hulls import bounding_sphere
            from wbc.collision.model import CollisionModel

            cm = CollisionModel(robot, self_collision=True)
            gm = cm.geometry_model
            g = gm.geometryObjects[gm.getGeometryId("torso_2_link_0")]
            centre = bounding_sphere(g.geometry)[0]
            pin.framesForwardKinematics(m, d, self.q0)
            self.hand = (d.oMi[g.parentJoint] * g.placement).act(centre)
        else:
            self.hand = d.oMf[m.getFrameId(HAND)].translation + HAND_OFFSET

    def errors(self, q: np.ndarray) -> dict:
        m, d = self.model, self.data
        pin.framesForwardKinematics(m, d, q)
        com = pin.centerOfMass(m, d, q)
        feet = max(float(np.linalg.norm(pin.log6(d.oMf[m.getFrameId(f)].actInv(T)).vector))
                   for f, T in self.feet.items())
        return {"hand": float(np.linalg.norm(d.oMf[m.getFrameId(HAND)].translation - self.hand)),
                "com": float(np.linalg.norm(com - self.com)), "feet": feet,
                "posture": float(np.linalg.norm(pin.difference(m, q, self.q0)[6:]))}


# --------------------------------------------------------------------------- the solvers
class WbcIK:
    name = "wbc hqp (velocity mode)"

    def __init__(self, pb: Problem, collisions: bool = False) -> None:
        feet = [Contact("left_foot"), Contact("right_foot")]
        com = CoM(target=pb.com)
        hand = Frame("right_hand", mask="position", target=pb.hand)
        level0 = [*feet, JointLimits(horizon=DT)]       # the peers enforce joint limits by default
        if pb.torso is not None:
            level0.append(Frame("torso", target=pb.torso))
        if collisions:
            # ξ DT = half of d_i − d_s: one full step closes at most half the gap to d_s (first order)
            level0.append(CollisionAvoidance(influence=0.05, safety=0.01, max_speed=0.5 * 0.04 / DT, max_rows=32))
        # full Gauss–Newton steps on the reachable problem; a tenth of the error per step on the
        # unreachable one (full steps towards a target 0.5 m away leave the linearisation: the
        # first step moved the feet by 0.33 m)
        self.ctrl = Controller(pb.robot, Stack([level0, [com], [hand], [Posture(target=pb.q0)]]), mode="velocity",
                               dt=DT, gain=(STEP if collisions else 1.0) / DT)
        self.q = pb.q0.copy()

    def timed(self) -> None:
        self.ctrl.solve(self.q)

    def solve(self, q: np.ndarray) -> np.ndarray:
        """Δq (one full step) at q."""
        return self.ctrl.solve(q).qd * DT


class PlacoIK:
    name = "PlaCo 0.10.2 KinematicsSolver"

    def __init__(self, pb: Problem, collisions: bool = False) -> None:
        import placo

        from benchmarks.harness.placo_peer import _pin_to_placo, _placo_to_pin

        os.environ["ROS_PACKAGE_PATH"] = pb.robot.package_dirs[0]
        flags = 0 if collisions else placo.Flags.ignore_collisions
        self.rw = rw = placo.RobotWrapper(str(pb.robot.urdf_path), flags)
        self.pin_model = pb.model
        self.to_placo = lambda q: _pin_to_placo(q, pb.model, rw.model)
        self.to_pin = lambda q: _placo_to_pin(q, rw.model, pb.model)
        rw.state.q = self.q0 = self.to_placo(pb.q0)
        rw.update_kinematics()
        s = self.solver = placo.KinematicsSolver(rw)
        s.dt = DT
        s.mask_fbase(False)
        s.enable_joint_limits(True)
        for f in SOLES:
            s.add_frame_task(f, pb.feet[f].homogeneous).configure(f, "hard", 1.0, 1.0)
        if pb.torso is not None:
            s.add_frame_task(TORSO, pb.torso.homogeneous).configure("torso", "hard", 1.0, 1.0)
        s.add_com_task(pb.com).configure("com", "hard", 1.0)
        s.add_position_task(HAND, pb.hand).configure("hand", "soft", 1.0)
        post = s.add_joints_task()
        post.set_joints({n: rw.get_joint(n) for n in rw.joint_names()})
        post.configure("posture", "soft", 1e-4)
        if collisions:
            s.add_avoid_self_collisions_constraint()

    def timed(self) -> None:
        self.rw.state.q = self.q0
        self.rw.update_kinematics()
        self.solver.solve(False)

    def solve(self, q: np.ndarray) -> np.ndarray:
        rw = self.rw
        rw.state.q = self.to_placo(q)
        rw.update_kinematics()
        self.solver.solve(True)                  # Δq applied to its state: read it back in pinocchio's order
        return pin.difference(self.pin_model, q, self.to_pin(np.array(rw.state.q)))


class PinkIK:
    name = "pink 4.4.0 solve_ik (daqp)"

    def __init__(self, pb: Problem, collisions: bool = False) -> None:
        import pink
        from pink import tasks

        self.pink = pink
        m = pb.model
        self.geom = None
        if collisions:
            from wbc.collision.model import CollisionModel

            cm = CollisionModel(pb.robot, self_collision=True)
            self.geom = (cm.geometry_model, pin.GeometryData(cm.geometry_model))
        self.conf = pink.Configuration(m, m.createData(), pb.q0.copy(), collision_model=self.geom and self.geom[0],
                                       collision_data=self.geom and self.geom[1])
        feet = []
        for f in SOLES:
            t = tasks.FrameTask(f, position_cost=1.0, orientation_cost=1.0)
            t.set_target(pb.feet[f])
            feet.append(t)
        if pb.torso is not None:
            t = tasks.FrameTask(TORSO, position_cost=1.0, orientation_cost=1.0)
            t.set_target(pb.torso)
            feet.append(t)
        gain = STEP if collisions else 1.0
        com = tasks.ComTask(cost=1.0, gain=gain)
        com.set_target(pb.com)
        hand = tasks.FrameTask(HAND, position_cost=1.0, orientation_cost=0.0, gain=gain)
        T = pin.SE3(np.eye(3), pb.hand)
        hand.set_target(T)
        post = tasks.PostureTask(cost=1e-2, gain=gain)
        post.set_target(pb.q0)
        self.tasks, self.constraints = [com, hand, post], feet
        self.q0 = pb.q0.copy()
        self.barriers = None
        if collisions:
            from pink.barriers import SelfCollisionBarrier

            self.barriers = [SelfCollisionBarrier(n_collision_pairs=len(self.geom[0].collisionPairs), d_min=0.01)]

    def timed(self) -> None:
        self.conf.update(self.q0)
        self.pink.solve_ik(self.conf, self.tasks, DT, solver="daqp", constraints=self.constraints,
                           barriers=self.barriers, safety_break=False)

    def solve(self, q: np.ndarray) -> np.ndarray:
        self.conf.update(q)
        v = self.pink.solve_ik(self.conf, self.tasks, DT, solver="daqp", constraints=self.constraints,
                               barriers=self.barriers, safety_break=False)
        return v * DT


class MinkIK:
    name = "mink 1.3.0 solve_ik (daqp, MuJoCo model)"

    def __init__(self, pb: Problem, collisions: bool = False) -> None:
        """MuJoCo's compilation of the URDF fuses the fixed sole and gripper links into their
        parents: the feet are held on leg_*_6_link (the same constraint), the hand task is on
        arm_right_7_link's origin, its target the gripper target minus the gripper's offset at
        q0's orientation (the hand error is measured on the gripper, so it shows the difference)."""
        import mink

        from wbc.sim.mujoco_sim import MujocoSimulator

        self.mink, self.pb = mink, pb
        sim = self.sim = MujocoSimulator.for_robot(pb.robot, [])
        mm = sim.mj_model
        self.conf = mink.Configuration(mm)
        self.conf.update(sim.qpos_from_q(pb.q0))
        self.q0 = sim.qpos_from_q(pb.q0)
        m, d = pb.model, pb.data
        pin.framesForwardKinematics(m, d, pb.q0)
        tasks = []
        for body in ("leg_left_6_link", "leg_right_6_link"):
            t = mink.FrameTask(body, "body", position_cost=1.0, orientation_cost=1.0)
            t.set_target(mink.SE3.from_matrix(d.oMf[m.getFrameId(body)].homogeneous))
            tasks.append(t)
        com = mink.ComTask(cost=1.0)
        com.set_target(pb.com)
        wrist = d.oMf[m.getFrameId("arm_right_7_link")]
        grip = d.oMf[m.getFrameId(HAND)]
        hand = mink.FrameTask("arm_right_7_link", "body", position_cost=1.0, orientation_cost=0.0)
        hand.set_target(mink.SE3.from_translation(pb.hand - (grip.translation - wrist.translation)))
        post = mink.PostureTask(mm, cost=1e-2)
        post.set_target(sim.qpos_from_q(pb.q0))
        self.tasks, self.constraints = [com, hand, post], tasks

    def timed(self) -> None:
        self.conf.update(self.q0)
        self.mink.solve_ik(self.conf, self.tasks, DT, solver="daqp", constraints=self.constraints)

    def solve(self, q: np.ndarray) -> np.ndarray:
        self.conf.update(self.sim.qpos_from_q(q))
        v = self.mink.solve_ik(self.conf, self.tasks, DT, solver="daqp", constraints=self.constraints)
        self.conf.integrate_inplace(v, DT)
        return pin.difference(self.pb.model, q, self.sim.q_from_qpos(self.conf.q))


# --------------------------------------------------------------------------- the runs
def available(pb: Problem, collisions: bool) -> list:
    out = [WbcIK(pb, collisions)]
    for cls in (PlacoIK, PinkIK) + (() if collisions else (MinkIK,)):
        try:
            s = cls(pb, collisions)
        except ImportError as exc:
            print(f"<!-- {cls.name}: not in this environment ({exc}) -->")
            continue
        out.append(s)
    return out


def timing(solvers: list, q0: np.ndarray, rounds: int, clock=time.perf_counter) -> np.ndarray:
    """Per solver, the time of each of ``rounds`` solves at q0, solvers interleaved (s), by
    ``clock`` (``time.thread_time`` with ``--clock cpu``: this thread's CPU time, which the
    other processes of a loaded machine do not add to)."""
    t = np.empty((len(solvers), rounds))
    for s in solvers:                # warm-up: compiled kernels, QP objects
        for _ in range(20):
            s.timed()
    for r in range(rounds):
        for i, s in enumerate(solvers):
            t0 = clock()
            s.timed()
            t[i, r] = clock() - t0
    return t


def converge(pb: Problem, s, distances=None) -> tuple[np.ndarray, int, float]:
    """(final q, iterations, smallest monitored distance on the way) from q0."""
    q, dmin, still = pb.q0.copy(), np.inf, 0
    for k in range(MAX_ITER if distances is None else 3 * MAX_ITER):
        try:
            dq = s.solve(q)
        except Exception as exc:  # noqa: BLE001 (a peer's QP that failed: reported, the run stops there)
            print(f"<!-- {s.name}: {type(exc).__name__} at iteration {k + 1}: {exc} -->")
            return q, -(k + 1), dmin
        q = pin.integrate(pb.model, q, dq)
        if distances is not None:
            dmin = min(dmin, distances(q))
        if np.linalg.norm(dq) >= 1e-9:
            still = 0
        elif distances is None or still == 2:     # converged (collisions: three zero steps in a row,
            return q, k + 1 - still, dmin         # as wbc's step check may hold one step and not the next)
        else:
            still += 1
    return q, k + 1, dmin


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=2000)
    ap.add_argument("--unreachable", action="store_true")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="wall: perf_counter; cpu: the thread's CPU time (a loaded machine)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    robot = load_robot("talos")
    pb = Problem(robot, args.unreachable)
    solvers = available(pb, args.unreachable)
    print(f"pinocchio {pin.__version__}; load {os.getloadavg()[0]:.2f}\n")
    distances = None
    if args.unreachable:
        from wbc.collision.model import CollisionModel

        cm = CollisionModel(robot, self_collision=True)
        arm = [k for k in range(len(cm.pairs)) if "arm_right" in cm.pair_name(k) or "gripper_right" in cm.pair_name(k)]
        arm = [k for k in arm if "torso" in cm.pair_name(k) or "base_link" in cm.pair_name(k)]
        data = robot.model.createData()

        def distances(q):
            return float(cm.all_distances(q, data)[arm].min())

        print("| solver | iterations | hand error (m) | min arm–torso distance (m) | feet drift (m) | CoM error (m) |")
        print("|---|---|---|---|---|---|")
        for s in solvers:
            q, n, dmin = converge(pb, s, distances)
            e = pb.errors(q)
            print(f"| {s.name} | {n} | {e['hand']:.4f} | {dmin:.4f} | {e['feet']:.2e} | {e['com']:.2e} |")
        return
    t = timing(solvers, pb.q0, args.rounds, time.thread_time if args.clock == "cpu" else time.perf_counter)
    med = np.median(t, axis=1) * 1e3
    print("| solver | time per solve, median (ms) | p90 (ms) | ratio to wbc | iterations | hand error (m) "
          "| CoM error (m) | feet drift (m, rad) | posture ‖q0 ⊖ q‖ (rad) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i, s in enumerate(solvers):
        q, n, _ = converge(pb, s)
        e = pb.errors(q)
        print(f"| {s.name} | {med[i]:.4f} | {np.percentile(t[i], 90) * 1e3:.4f} | {med[i] / med[0]:.2f} | {n} "
              f"| {e['hand']:.1e} | {e['com']:.1e} | {e['feet']:.1e} | {e['posture']:.4f} |")


if __name__ == "__main__":
    main()
