"""Joint-space control of the Panda arm (chapter 5.2.1): PD + gravity, inverse dynamics, Slotine-Li, PID.

Five phases, one after the other, on a pinocchio simulation of the arm (ABA,
semi-implicit Euler at 1 kHz, no contacts):

1. PD + gravity compensation (5.5) regulates to a posture 0.5 rad away;
2. inverse dynamics (5.2-5.3) tracks a moving joint trajectory from a 0.1 rad
   offset, the error following ë + K_d ė + K_p e = 0;
3. Slotine-Li (5.6) with a 40 % wrong parameter estimate, first fixed, then adaptive;
4. independent-joint PID (decentralised control) on one trajectory: alone, with
   decentralised feedforward (b̄_ii q̈_d), with centralised feedforward (RNEA at q_d);
5. robust Slotine-Li on the arm carrying a 2 kg payload the controller believes is
   30 % lighter: the ultimate tracking error for three boundary layers ε, and the
   sampling margin of the same law with one norm bound over all 70 parameters.

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

    import pinocchio as pin

    import wbc
    from wbc.chapter import (
        IndependentJointPID,
        InverseDynamics,
        PassivityBased,
        PDGravity,
        RobustPassivityBased,
        body_parameter_indices,
        body_parameter_scale,
        dynamic_parameters,
        with_payload,
    )
    from wbc.sim import Simulator
    from wbc.trajectories.position import Sinusoid

    robot = wbc.load_robot("panda")
    view = ArmView(robot, live)
    q0 = robot.q_default.copy()
    sim = Simulator(robot.model, [], [], q0, dt=DT)
    clock = [0.0]       # the view's time across phases (a phase may bring its own simulator)

    def run(ctrl, duration, ref=None, plant=None):
        """Closed loop for ``duration`` s on ``plant`` (default the shared simulator);
        returns times, |e| per step, peak |τ| per joint."""
        plant = sim if plant is None else plant
        t_start = plant.t
        T, E, tau_max = [], [], np.zeros(robot.nv)
        for _ in range(round(duration / DT)):
            t = plant.t - t_start
            tau = ctrl(plant.q, plant.v, t)
            tau_max = np.maximum(tau_max, np.abs(tau))
            if ref is not None:
                T.append(t)
                E.append(np.linalg.norm(ref(t)[0] - plant.q))
            plant.step(tau)
            clock[0] += DT
            view.draw(plant.q, clock[0])
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
    # 4. independent-joint PID, three levels of feedforward, same gains (triple pole at −20 rad/s per joint)
    q_pid = robot.q_default.copy()
    wave = Sinusoid(amplitude=np.array([0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5]), frequency=0.4, ramp=1.0)

    def pid_ref(t):                      # hold 1 s (the integral takes up gravity), then move
        x, dx, ddx = wave.sample(max(t - 1.0, 0.0))
        return q_pid + x, dx, ddx

    rms = {}
    for ff in ("none", "decentralized", "centralized"):
        sim.q, sim.v = q_pid.copy(), np.zeros(robot.nv)
        T, E, tm = run(IndependentJointPID.tuned(robot, pid_ref, bandwidth=20.0, feedforward=ff), 4.5, pid_ref)
        rms[ff] = np.sqrt(np.mean(E[T >= 1.0] ** 2))
        print(f"4. independent-joint PID, feedforward {ff:13s}: RMS tracking error {rms[ff] * 1e3:6.2f} mrad; "
              f"{limits(tm)}")
    print(f"   centralised < decentralised < none: {rms['centralized'] < rms['decentralized'] < rms['none']}")
    # 5. robust Slotine-Li, a 2 kg payload the controller believes is 1.4 kg
    payload = pin.Inertia(2.0, np.array([0.03, 0.0, 0.2]), np.diag([3e-3, 3e-3, 2e-3]))
    S = body_parameter_indices(robot.model)
    pi0 = dynamic_parameters(robot.model)
    pi0[S] += 0.7 * payload.toDynamicParameters()
    scale = body_parameter_scale(0.2)
    rho = 1.25 * np.linalg.norm(0.3 * payload.toDynamicParameters() / scale)
    wave5 = Sinusoid(amplitude=np.array([0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5]), frequency=0.4, ramp=0.0)

    def ref(t):                          # about the arm's default posture, started 0.1 rad off
        x, dx, ddx = wave5.sample(t)
        return q_pid + x, dx, ddx

    heavy = with_payload(robot.model, payload)

    def margin(ctrl):
        return max(ctrl.sampling_margin(ref(t)[0], ref(t)[1], t, DT) for t in np.linspace(0.0, 2.5, 11))

    print(f"5. robust Slotine-Li, 2 kg payload estimated 30 % light; uncertain: the last body's 10 parameters "
          f"(lengths in 0.2 m), ρ = {rho:.2f}")
    for eps in (None, 3.0, 1.0, 0.3):
        plant = Simulator(heavy, [], [], q_pid + 0.1, dt=DT)
        ctrl = (PassivityBased(robot, ref, kd=kd, lam=5.0, params=pi0) if eps is None else
                RobustPassivityBased(robot, ref, kd=kd, lam=5.0, rho=rho, eps=eps, params=pi0, scale=scale))
        T, E, tm = run(ctrl, 4.0, ref, plant)
        label = "δπ = 0 (nominal π₀)" if eps is None else f"ε = {eps:<4g}  sampling margin {margin(ctrl):.2f}"
        print(f"   {label:34s}: ultimate max |e| {E[T >= 1.5].max() * 1e3:6.1f} mrad; {limits(tm)}")
    all70 = RobustPassivityBased(robot, ref, kd=kd, lam=5.0, rho=0.3 * np.linalg.norm(pi0 / np.tile(scale, 7)),
                                 eps=0.3, params=pi0, uncertain="all", scale=np.tile(scale, 7))
    print(f"   one norm bound over all 70 parameters, ε = 0.3: sampling margin {margin(all70):.1f} "
          f"(> 1: the torque chatters at 1 kHz)")
    view.finish(args.record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
