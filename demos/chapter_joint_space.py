"""Joint-space control of the Panda arm (chapter 5.2.1): PD + gravity, inverse dynamics, adaptive Slotine-Li.

Three phases, one after the other, on a pinocchio simulation of the arm (ABA,
semi-implicit Euler at 1 kHz, no contacts):

1. PD + gravity compensation (5.5) regulates to a posture 0.5 rad away;
2. inverse dynamics (5.2-5.3) tracks a moving joint trajectory from a 0.1 rad
   offset, the error following ë + K_d ė + K_p e = 0;
3. Slotine-Li (5.6) with a 40 % wrong parameter estimate, first fixed, then adaptive.

Prints the figures; with --viz (or a display) it plays live in the browser (Meshcat,
127.0.0.1); otherwise it writes a self-contained HTML replay under recordings/.

    python demos/chapter_joint_space.py [--viz | --headless] [--record PATH]
"""

from __future__ import annotations

import sys

import numpy as np

DT = 1e-3


def main() -> int:
    from _arm_view import ArmView, demo_args

    args, live = demo_args(__doc__, "chapter_joint_space")

    import wbc
    from wbc.control import (
        InverseDynamics,
        PassivityBased,
        PDGravity,
        dynamic_parameters,
    )
    from wbc.sim import Simulator
    from wbc.trajectories import Sinusoid

    robot = wbc.load_robot("panda")
    view = ArmView(robot, live)
    q0 = robot.q_default.copy()
    sim = Simulator(robot.model, [], [], q0, dt=DT)

    def run(ctrl, duration, ref=None):
        """Closed loop for ``duration`` s; returns times, |e| per step, peak |τ| per joint."""
        t_start = sim.t
        T, E, tau_max = [], [], np.zeros(robot.nv)
        for k in range(round(duration / DT)):
            t = sim.t - t_start
            tau = ctrl(sim.q, sim.v, t)
            tau_max = np.maximum(tau_max, np.abs(tau))
            if ref is not None:
                T.append(t)
                E.append(np.linalg.norm(ref(t)[0] - sim.q))
            sim.step(tau)
            view.draw(sim.q, sim.t)
        return np.array(T), np.array(E), tau_max

    def moving(amplitude, frequency):
        s = Sinusoid(amplitude=np.asarray(amplitude, float), frequency=frequency, ramp=0.0)

        def ref(t):
            x, dx, ddx = s.sample(t)
            return q0 + x, dx, ddx
        return ref

    def limits(tau_max):
        return f"peak |τ| / limit: {np.max(tau_max / robot.tau_max):.0%}"

    print("Panda, joint-space control (chapter 5.2.1), pinocchio ABA + semi-implicit Euler at 1 kHz")
    # 1. PD + gravity (5.5)
    qd = q0 + np.array([0.4, -0.3, 0.3, 0.4, -0.4, 0.3, 0.5])
    pd = PDGravity(robot, qd, kp=[100.0] * 4 + [20.0] * 3, kd=[20.0] * 4 + [2.0] * 3)
    V0 = pd.lyapunov(sim.q, sim.v)
    _, _, tm = run(pd, 2.5)
    print(f"1. PD + g (5.5): |q − q_d|∞ 0.50 → {np.abs(sim.q - qd).max():.1e} rad in 2.5 s, "
          f"Lyapunov V {V0:.1f} → {pd.lyapunov(sim.q, sim.v):.1e} J; {limits(tm)}")
    # 2. inverse dynamics (5.2-5.3), from a 0.1 rad offset onto a moving trajectory
    q0 = sim.q.copy()
    ref = moving([0.2] * 7, 0.5)
    sim.q = q0 + 0.1
    sim.v[:] = 0.0
    w = 10.0
    e0 = ref(0.0)[0] - sim.q
    de0 = ref(0.0)[1] - sim.v
    T, E, tm = run(InverseDynamics(robot, ref, kp=w * w), 2.5, ref)
    analytic = np.linalg.norm((e0 + np.outer(T, de0 + w * e0)) * np.exp(-w * T)[:, None], axis=1)
    print(f"2. inverse dynamics (5.2-5.3), K_p = {w * w:.0f}, K_d = {2 * w:.0f}: |e| {E[0]:.3f} rad → "
          f"{E[-1] * 1e3:.2f} mrad; max deviation from the analytic solution of ë + K_d ė + K_p e = 0: "
          f"{np.abs(E - analytic).max() / E[0]:.2%} of |e0| (the O(h) of the integrator); {limits(tm)}")
    # 3. Slotine-Li with a wrong estimate, fixed then adaptive
    pi = dynamic_parameters(robot.model)
    kd = np.array([10.0] * 4 + [2.0] * 3)
    ref = moving([0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5], 0.4)
    for label, gain in (("fixed   ", None), ("adaptive", np.where(np.arange(pi.size) % 10 == 0, 5.0, 0.5))):
        sim.q, sim.v = q0 + 0.1, np.zeros(robot.nv)
        ctrl = PassivityBased(robot, ref, kd=kd, lam=5.0, params=0.6 * pi, adapt_gain=gain)
        T, E, tm = run(ctrl, 5.0, ref)
        print(f"3. Slotine-Li (5.6), π̂(0) = 0.6 π, {label}: tracking error over the last 2 s "
              f"{E[T > 3.0].max() * 1e3:6.1f} mrad; {limits(tm)}")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
