"""Elastic-joint control of the Panda arm (chapter 5.2.2): motor PD + gravity, joint-torque feedback.

The arm's joints are springs between motors and links (5.7-5.8; K = 5000/2000 N·m/rad,
reflected motor inertias 0.4/0.1 kg·m²), simulated with pinocchio ABA for the links and
symplectic Euler at 10 kHz. Four runs towards the same posture:

1. motor-side PD (5.9) without gravity compensation: the arm sags;
2. the same with constant compensation τ_g = g(q_d), θ_d = q_d + K⁻¹ g(q_d): it reaches q_d;
3. torque feedback (5.10) with u = PD + g on the motor side, B_m/B_θ = 1 and 10 (5 kHz
   torque loop), compared with the rigid arm under PD + g (5.5).

Prints the figures; with --viz (or a display) it plays live in the browser (Meshcat,
127.0.0.1); otherwise it writes a self-contained HTML replay under recordings/.

    python demos/chapter_elastic_joints.py [--viz | --headless] [--record PATH]
"""

from __future__ import annotations

import sys

import numpy as np


def main() -> int:
    from _arm_view import ArmView, demo_args

    args, live = demo_args(__doc__, "chapter_elastic_joints")

    import wbc
    from wbc.chapter import MotorPD, PDGravity, TorqueFeedback
    from wbc.sim import Simulator
    from wbc.sim.elastic import ElasticJointSimulator

    robot = wbc.load_robot("panda")
    view = ArmView(robot, live)
    q0 = robot.q_default.copy()
    qd = q0 + np.array([0.3, -0.2, 0.3, 0.3, -0.3, 0.3, 0.4])
    clock = {"t": 0.0}           # the demo's time across its runs (for the view)

    def run(sim, ctrl, duration, show=True):
        """Closed loop on ``sim`` for ``duration`` s; the link trajectory (one row per period)."""
        Q = []
        for k in range(round(duration / sim.dt)):
            t = k * sim.dt
            sim.step(ctrl(sim.measure(), t) if isinstance(sim, ElasticJointSimulator) else ctrl(sim.q, sim.v, t))
            Q.append(sim.q.copy())
            if show:
                clock["t"] += sim.dt
                view.draw(sim.q, clock["t"])
        return np.array(Q)

    probe = ElasticJointSimulator(robot)
    print("Panda with elastic joints (chapter 5.2.2): K = "
          f"{probe.K[0]:.0f}/{probe.K[-1]:.0f} N·m/rad, B_m = {probe.B[0]}/{probe.B[-1]} kg·m²; "
          f"stiffest mode ω_max = {probe.omega_max:.0f} rad/s, h ω_max = {probe.h * probe.omega_max:.2f} at h = 0.1 ms")
    kp, kd = [300.0] * 4 + [50.0] * 3, [30.0] * 4 + [3.0] * 3
    for label, mode in (("without gravity compensation", "none"), ("with τ_g = g(q_d)", "constant")):
        sim = ElasticJointSimulator(robot)
        ctrl = MotorPD(robot, qd, sim.K, kp=kp, kd=kd, gravity=mode)
        Q = run(sim, ctrl, 2.5)
        q_eq, th_eq = ctrl.equilibrium()
        print(f"{'1' if mode == 'none' else '2'}. motor PD (5.9) {label:28s}: |q − q_d|∞ = "
              f"{np.abs(Q[-500:].mean(0) - qd).max() * 1e3:7.3f} mrad, |θ − θ_d|∞ = "
              f"{np.abs(sim.theta - th_eq).max() * 1e3:7.3f} mrad after 2.5 s "
              f"(θ_d − q_d up to {np.abs(th_eq - q_eq).max() * 1e3:.1f} mrad)")
    dt = 2e-4
    pd = PDGravity(robot, qd, kp=[200.0] * 4 + [20.0] * 3, kd=[30.0] * 4 + [2.0] * 3)
    QR = run(Simulator(robot.model, [], [], q0, dt=dt), pd, 1.5, show=False)
    for ratio in (1.0, 10.0):
        sim = ElasticJointSimulator(robot, dt=dt, substeps=2)
        Q = run(sim, TorqueFeedback(sim.B, sim.B / ratio, TorqueFeedback.rigid(pd)), 1.5)
        print(f"3. torque feedback (5.10), B_m/B_θ = {ratio:4.0f}: max |q − q_rigid| over 1.5 s = "
              f"{np.abs(Q - QR).max() * 1e3:5.1f} mrad (motion 400 mrad)")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
