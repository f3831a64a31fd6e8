"""Task-space control of the Panda arm (chapter 5.2.3): inverse dynamics with a null-space posture, then J^T PD + g.

On a pinocchio simulation of the arm (ABA, semi-implicit Euler at 1 kHz, no contacts):

1. task-space inverse dynamics (5.13-5.16) drives the hand along an 8 cm circle
   at 0.5 Hz, η a posture in the null space of the hand;
2. the null-space posture target is switched to swing the elbow: the arm's
   configuration changes, the hand's error does not (J N = 0);
3. Jacobian-transpose PD + gravity (5.20) regulates the hand to a fixed point.

Prints the figures; with --viz (or a display) it plays live in the browser (Meshcat,
127.0.0.1, the hand's target as a blue sphere); otherwise it writes a self-contained
HTML replay under recordings/.

    python demos/chapter_task_space.py [--viz | --headless] [--record PATH]
"""

from __future__ import annotations

import sys

import numpy as np

DT = 1e-3


def main() -> int:
    from _arm_view import ArmView, demo_args

    args, live = demo_args(__doc__, "chapter_task_space")


    import wbc
    from wbc.chapter import JacobianTransposePD, TaskSpaceInverseDynamics
    from wbc.sim import Simulator

    robot = wbc.load_robot("panda")
    hand, elbow = robot.frame_id("hand"), robot.frame_id("elbow")
    view = ArmView(robot, live, targets=["hand"])
    q0 = robot.q_default.copy()
    sim = Simulator(robot.model, [], [], q0, dt=DT)

    def positions(q):
        robot.update(q, np.zeros(robot.nv))
        return robot.frame_placement(hand).translation.copy(), robot.frame_placement(elbow).translation.copy()

    def run(ctrl, t0, duration):
        """Closed loop over [t0, t0 + duration); per step: hand error |x_d − x| (m), elbow position."""
        err, elb, tau_max = [], [], np.zeros(robot.nv)
        for k in range(round(duration / DT)):
            t = t0 + k * DT
            tau = ctrl(sim.q, sim.v, t)
            tau_max = np.maximum(tau_max, np.abs(tau))
            err.append(np.linalg.norm(ctrl.error(sim.q, t)))
            elb.append(positions(sim.q)[1])
            sim.step(tau)
            if view.due(t):
                view.draw(sim.q, t, targets={"hand": ctrl.reference(t)[0]})
        return np.array(err), np.array(elb), tau_max

    x0, _ = positions(q0)
    r, f = 0.08, 0.5
    w = 2 * np.pi * f

    def circle(t):
        """x_d(t): a circle of radius r (m) in the y-z plane through the start, f Hz."""
        s, c = np.sin(w * t), np.cos(w * t)
        return (x0 + r * np.array([0.0, s, 1.0 - c]), r * w * np.array([0.0, c, s]),
                r * w * w * np.array([0.0, -s, c]))

    print("Panda, task-space control (chapter 5.2.3), hand position task (m = 3, n = 7), 1 kHz")
    kp = 100.0
    tsid = TaskSpaceInverseDynamics(robot, "hand", circle, kp=kp, q_null=q0, null_kp=25.0, null_kd=10.0)
    e1, elb1, tm1 = run(tsid, 0.0, 4.0)
    print(f"1. inverse dynamics (5.13-5.16), K_p = {kp:.0f}, K_d = {2 * np.sqrt(kp):.0f}: hand error "
          f"after 1 s: rms {np.sqrt(np.mean(e1[1000:] ** 2)) * 1e3:.3f} mm, max {e1[1000:].max() * 1e3:.3f} mm")
    q_swing = q0 + np.array([0.5, 0.0, -0.6, 0.0, 0.0, 0.0, 0.0])
    tsid = TaskSpaceInverseDynamics(robot, "hand", circle, kp=kp, q_null=q_swing, null_kp=25.0, null_kd=10.0)
    e2, elb2, tm2 = run(tsid, 4.0, 4.0)
    print(f"2. null-space posture switched: the elbow moves {np.linalg.norm(elb2 - elb1[-1], axis=1).max() * 100:.1f} cm, "
          f"hand error max {e2.max() * 1e3:.3f} mm (before the switch {e1[1000:].max() * 1e3:.3f} mm)")
    x_goal = x0 + np.array([0.10, -0.12, -0.05])
    jt = JacobianTransposePD(robot, "hand", x_goal, kp=600.0, kd=[8.0] * 4 + [1.0] * 3)
    V0 = jt.lyapunov(sim.q, sim.v)
    e3, _, tm3 = run(jt, 8.0, 3.0)
    print(f"3. J^T PD + g (5.20), K_p = 600 N/m: |x − x_d| {e3[0] * 1e3:.0f} mm → {e3[-1] * 1e3:.3f} mm in 3 s; "
          f"Lyapunov V {V0:.2f} → {jt.lyapunov(sim.q, sim.v):.1e} J")
    peak = np.max(np.maximum(np.maximum(tm1, tm2), tm3) / robot.tau_max)
    print(f"   peak |τ| / torque limit over the run: {peak:.0%}")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
