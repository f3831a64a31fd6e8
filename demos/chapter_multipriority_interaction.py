"""Multi-priority interaction (chapter 5.3.5): the Panda carries a glass; a person pushes its elbow.

Main task: the hand's pose (the glass), a stiff task impedance (5.45-5.46).
Null space: a compliant impedance (5.43-5.44). On a pinocchio simulation with
external wrenches (wbc.sim.compliant, ABA + fext, 1 kHz):

1. selective compliance (NullSpaceImpedanceController): 25 N sideways on the elbow for
   1.5 s; the arm yields in its null space, the glass barely tilts;
2. non-selective compliance (joint PD + gravity with the same joint stiffness
   k_q everywhere): the same push tilts the glass;
3. a 10 N push down on the hand itself meets the task impedance: deflection
   K⁻¹h_e (5.46).

Prints the glass tilt, hand displacement and elbow displacement of each. Live in
the browser with --viz (or a display; pushes as purple arrows), else an HTML
replay under recordings/.

    python demos/chapter_multipriority_interaction.py [--viz | --headless]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
DT = 1e-3


def main() -> int:
    from _arm_view import ArmView, demo_args

    args, live = demo_args(__doc__, "chapter_multipriority_interaction")

    import pinocchio as pin

    import wbc
    from wbc.chapter import NullSpaceImpedanceController, PDGravity
    from wbc.sim.compliant import ExternalWrench, InteractionSim

    robot = wbc.load_robot("panda")
    q0 = robot.q_default.copy()
    K = np.diag([3000.0] * 3 + [100.0] * 3)       # N/m, N·m/rad: the glass is held stiffly
    D = np.diag([150.0] * 3 + [2.5] * 3)
    k_q, B_nu = 20.0, 3.0                           # N·m/rad, N·m·s/rad: a soft null space
    view = ArmView(robot, live, arrows={"elbow_push": "push", "hand_push": "push"}, m_per_newton=0.01)
    elbow_f, hand_f = np.array([0.0, 25.0, 0.0]), np.array([0.0, 0.0, -10.0])
    t_on, t_off, T = 0.3, 1.8, 2.8
    start = {"t": 0.0}

    def episode(ctrl, wrench, label):
        frame, force = wrench
        sim = InteractionSim(robot, q0, dt=DT, wrenches=[ExternalWrench(frame, force, start=t_on,
                                                                          duration=t_off - t_on)])
        ref_hand, ref_elbow = sim.frame_pose("hand"), sim.frame_pose("elbow").translation
        tilt = hand = elbow = 0.0
        for _ in range(round(T / DT)):
            tau = ctrl(sim.q, sim.v, sim.t)
            sim.step(tau)
            Mh = sim.frame_pose("hand")
            e = sim.frame_pose("elbow").translation
            tilt = max(tilt, np.linalg.norm(pin.log3(ref_hand.rotation.T @ Mh.rotation)))
            hand = max(hand, np.linalg.norm(Mh.translation - ref_hand.translation))
            elbow = max(elbow, np.linalg.norm(e - ref_elbow))
            if abs(sim.t - t_off) < DT / 2:
                held = Mh.translation - ref_hand.translation
            on = t_on <= sim.t < t_off
            p = Mh.translation if frame == "hand" else e
            view.draw(sim.q, start["t"] + sim.t, arrows={
                "elbow_push": (e, force if on and frame == "elbow" else np.zeros(3)),
                "hand_push": (p, force if on and frame == "hand" else np.zeros(3))})
        start["t"] += T
        print(f"  {label:47s} glass tilt {np.degrees(tilt):6.3f}°  hand moved {hand * 1e3:6.2f} mm "
              f"(at release {np.linalg.norm(held) * 1e3:5.2f} mm)  elbow moved {elbow * 1e2:4.1f} cm")

    print(f"Panda carrying a glass; task K = {K[0, 0]:.0f} N/m, {K[3, 3]:.0f} N·m/rad; "
          f"null space k_q = {k_q} N·m/rad, B_ν = {B_nu} N·m·s/rad; pushes on [{t_on}, {t_off}) s")
    episode(NullSpaceImpedanceController(robot, "hand", K=K, D=D, k_q=k_q, B_nu=B_nu), ("elbow", elbow_f),
            "1. null-space impedance, 25 N on the elbow:")
    episode(PDGravity(robot, q0, kp=k_q, kd=B_nu), ("elbow", elbow_f),
            "2. joint PD + g (not selective), same push:")
    episode(NullSpaceImpedanceController(robot, "hand", K=K, D=D, k_q=k_q, B_nu=B_nu), ("hand", hand_f),
            "3. null-space impedance, 10 N down on the hand:")
    print(f"     (task impedance 5.46 at rest: K x̃ = h_e, |K⁻¹h_e| = {np.linalg.norm(hand_f) / K[2, 2] * 1e3:.2f} mm)")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
