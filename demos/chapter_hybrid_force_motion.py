"""Hybrid force/motion control (chapter 5.3.3): the Panda's hand presses a table with
10 N while sliding a 5 cm path along it.

Environment (wbc.sim.compliant): a horizontal plane through the fingertips' start,
spring-damper contact K_e = 1e4 N/m, D_e = 30 N·s/m, Coulomb friction μ
(default 0.3; 0 for the chapter's frictionless case), semi-implicit Euler at
1 kHz. The controller: force along the constrained direction (−z) with the
chapter's PI force law, motion along the five free directions (x, y, rotations),
the measured wrench fed back so that force and motion are decoupled.

Prints the force error, the sliding error, and the coupling: the force trace
while sliding minus the force trace of the same run holding still. Live in the
browser with --viz (or a display; the table, the target and the contact force
as an arrow), else an HTML replay under recordings/.

    python demos/chapter_hybrid_force_motion.py [--mu 0.3] [--force 10] [--viz | --headless]
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
    parser.add_argument("--mu", type=float, default=0.3, help="Coulomb friction coefficient of the table")
    parser.add_argument("--force", type=float, default=10.0, help="desired pressing force λ_D (N)")
    parser.add_argument("--duration", type=float, default=6.0)
    args, live = demo_args(__doc__, "chapter_hybrid_force_motion", parser)


    import wbc
    from wbc.chapter import HybridForceMotion
    from wbc.sim.compliant import CompliantPlane, InteractionSim

    robot = wbc.load_robot("panda")
    robot.update(robot.q_default, np.zeros(robot.nv))
    p0 = robot.frame_placement(robot.frame_id("hand")).copy()
    A, w, t0 = 0.05, 2 * np.pi * 0.4, 1.0

    def path(amplitude):
        """From rest at t0: x = A(1 − cos ωs), y = A sin²(ωs) (m), s = t − t0; orientation held."""
        def ref(t):
            s = max(0.0, t - t0)
            c, si = np.cos(w * s), np.sin(w * s)
            P = p0.copy()
            P.translation = p0.translation + amplitude * np.array([1 - c, si ** 2, 0.0])
            vel = amplitude * w * np.array([si, np.sin(2 * w * s), 0, 0, 0, 0])
            acc = float(t >= t0) * amplitude * w * w * np.array([c, 2 * np.cos(2 * w * s), 0, 0, 0, 0])
            return P, vel, acc
        return ref

    tip = np.array([0.0, 0.0, 0.1034])        # fingertip in the hand frame (m): the point that touches
    table = p0.act(tip)

    def run(amplitude, view=None):
        plane = CompliantPlane(table, [0.0, 0.0, 1.0], frame="hand", offset=tip, stiffness=1e4, damping=30.0,
                               mu=args.mu)
        sim = InteractionSim(robot, robot.q_default, dt=DT, surfaces=[plane])
        ctrl = HybridForceMotion(robot, "hand", force_directions=[0.0, 0.0, -1.0], force=args.force,
                                 motion=path(amplitude))
        log = {"t": [], "lam": [], "slide": [], "ft": []}
        for _ in range(round(args.duration / DT)):
            h_e = sim.sensor_wrench("hand")
            tau = ctrl(sim.q, sim.v, sim.t, h_e=h_e)
            log["t"].append(sim.t)
            log["lam"].append(ctrl.last["lambda"][0])
            log["slide"].append(np.linalg.norm(ctrl.last["pose_error"][:2]))
            log["ft"].append(np.linalg.norm(h_e[:2]))
            if view is not None:
                fingertip = sim.frame_pose("hand").act(tip)
                target = ctrl.reference(sim.t, p0)[0].act(tip)
                view.draw(sim.q, sim.t, arrows={"contact": (fingertip, -h_e[:3])}, targets={"hand": target})
            sim.step(tau)
        return {k: np.array(v) for k, v in log.items()}

    print(f"Panda hand on a table (K_e = 1e4 N/m, μ = {args.mu}): press λ_D = {args.force} N, slide 5 cm "
          f"from t = {t0} s at 0.4 Hz; 1 kHz")
    view = ArmView(robot, live, arrows={"contact": "contact"}, targets=["hand"], m_per_newton=0.01)
    view.plate(table, [0.0, 0.0, 1.0])
    slide = run(A, view)
    hold = run(0.0)
    late = slide["t"] > 2.0
    moving = slide["t"] > t0
    err = np.abs(slide["lam"][late] - args.force)
    print(f"  force: λ(0.1 s) = {slide['lam'][100]:.2f} N; error after 2 s: max {err.max() * 1e3:.1f} mN, "
          f"final {abs(slide['lam'][-1] - args.force) * 1e3:.2f} mN")
    print(f"  motion: sliding error while moving max {slide['slide'][moving].max() * 1e3:.3f} mm, "
          f"rms {np.sqrt(np.mean(slide['slide'][moving] ** 2)) * 1e3:.3f} mm")
    print(f"  coupling: |λ_sliding − λ_holding| max {np.abs(slide['lam'] - hold['lam']).max() * 1e3:.2f} mN; "
          f"friction force while sliding up to {slide['ft'].max():.2f} N (measured, cancelled)")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
