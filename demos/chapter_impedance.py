"""Stiffness, impedance and admittance control of the Panda's hand (chapter 5.3.4).

The same experiment for each controller, on a pinocchio simulation of the arm
(ABA with external wrenches, semi-implicit Euler at 1 kHz, wbc.sim.compliant):
the hand holds a pose; at 0.2 s a push of 6 N along x and −3 N along z is applied
to it for 1.2 s, then released. The three share the stiffness K_P = 300 N/m and
damping K_D = 30 N·s/m:

- stiffness (5.34): no force sensing; the hand deflects by K_P⁻¹h_e, with the
  robot's own inertia Λ_e(q) (5.35);
- impedance (5.36): force feedback; the closed loop is 5.37 with the chosen
  inertia K_M = 1.5 kg;
- admittance: 5.37 integrated to a compliant frame, tracked by a stiff inner
  motion loop; same closed loop, and robust to unmodelled joint friction
  (try --joint-friction 3).

Prints, per controller: steady deflection vs K_P⁻¹h_e, and the deviation of the
response from the K_M mass-spring-damper. Live in the browser with --viz (or a
display), else an HTML replay under recordings/.

    python demos/chapter_impedance.py [--mode all|stiffness|impedance|admittance] [--joint-friction D] [--viz | --headless]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
DT = 1e-3


def main() -> int:
    from _arm_view import ArmView, demo_args

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mode", default="all", choices=["all", "stiffness", "impedance", "admittance"])
    parser.add_argument("--joint-friction", type=float, default=0.0,
                        help="viscous joint friction in the simulated arm, unknown to the controllers (N·m·s/rad)")
    args, live = demo_args(__doc__, "chapter_impedance", parser)

    from scipy.linalg import expm

    import wbc
    from wbc.chapter import AdmittanceControl, ImpedanceControl, StiffnessControl
    from wbc.sim.compliant import ExternalWrench, InteractionSim

    robot = wbc.load_robot("panda")
    view = ArmView(robot, live, arrows={"push": "push"}, m_per_newton=0.03)
    KM = np.diag([1.5] * 3 + [0.05] * 3)
    KD = np.diag([30.0] * 3 + [1.0] * 3)
    KP = np.diag([300.0] * 3 + [20.0] * 3)
    push, t_on, t_off, T = np.array([6.0, 0.0, -3.0]), 0.2, 3.2, 4.0
    h_e = np.concatenate([-push, np.zeros(3)])
    makers = {
        "stiffness": lambda: StiffnessControl(robot, "hand", kp=KP, kd=KD),
        "impedance": lambda: ImpedanceControl(robot, "hand", km=KM, kd=KD, kp=KP),
        "admittance": lambda: AdmittanceControl(robot, "hand", dt=DT, km=KM, kd=KD, kp=KP, inner_kp=4e4),
    }
    modes = list(makers) if args.mode == "all" else [args.mode]
    print(f"Panda hand, push {push} N on [{t_on}, {t_off}) s; K_P = 300 N/m, K_D = 30 N·s/m, K_M = 1.5 kg; "
          f"joint friction in the plant {args.joint_friction} N·m·s/rad")

    def km_model(t):
        n = 6
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(KM, KP), -np.linalg.solve(KM, KD)]])
        z_ss = np.concatenate([np.linalg.solve(KP, h_e), np.zeros(n)])
        return (z_ss - expm(A * t) @ z_ss)[:3]

    t_show = 0.0
    for mode in modes:
        ctrl = makers[mode]()
        sim = InteractionSim(robot, robot.q_default, dt=DT, joint_damping=args.joint_friction,
                             wrenches=[ExternalWrench("hand", push, start=t_on, duration=t_off - t_on)])
        dev, peak, lam = 0.0, 0.0, None
        for _ in range(round(T / DT)):
            if mode == "stiffness":
                tau = ctrl(sim.q, sim.v, sim.t)
            else:
                tau = ctrl(sim.q, sim.v, sim.t, h_e=sim.sensor_wrench("hand"))
            dx = ctrl.last["dx"][:3]
            if t_on <= sim.t < t_off:
                dev = max(dev, np.linalg.norm(dx - km_model(sim.t - t_on)))
                peak = max(peak, np.linalg.norm(dx))
                if lam is None:
                    lam = ctrl.last["Lambda"][:3, :3].copy()
            if abs(sim.t - (t_off - DT)) < DT / 2:
                steady = dx.copy()
            hand = sim.frame_pose("hand").translation
            on = t_on <= sim.t < t_off
            view.draw(sim.q, t_show + sim.t, arrows={"push": (hand, push if on else np.zeros(3))})
            sim.step(tau)
        t_show += T
        pred = np.linalg.solve(KP[:3, :3], h_e[:3])
        def mm(x):
            return "(" + ", ".join(f"{1e3 * c:+.2f}" for c in x) + ") mm"

        print(f"  {mode:10s}: deflection at release {mm(steady)}, K_P⁻¹h_e {mm(pred)}; "
              f"peak {peak * 1e3:.1f} mm; max deviation from the K_M model {dev * 1e3:.2f} mm")
        if mode == "stiffness":
            print(f"              (its inertia is the robot's: Λ_e translational diagonal {np.round(np.diag(lam), 2)} kg)")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
