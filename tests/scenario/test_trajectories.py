"""Trajectory library (wbc.trajectories.position, wbc.trajectories.rotation): per-axis sinusoid phases and
circles, C² splines, orientation trajectories (ω and ω̇ against finite differences of R(t)),
their validation, ``events: add`` with a target, and a closed-loop Talos hand circle + rotation."""

from __future__ import annotations

import textwrap

import numpy as np
import pinocchio as pin
import pytest

from wbc.errors import ConfigError
from wbc.trajectories.position import Spline, Waypoints, build_trajectory, frame_reference
from wbc.trajectories.rotation import build_rotation

DT = 1e-3


def _fd(traj, t: float, h: float = 1e-6):
    """Central differences of sample()'s position and velocity at t."""
    xp, dxp, _ = traj.sample(t + h)
    xm, dxm, _ = traj.sample(t - h)
    return (xp - xm) / (2 * h), (dxp - dxm) / (2 * h)


def _so3_fd(rot, t: float, h: float = 1e-5):
    """ω ≈ log₃(R(t+h) R(t−h)ᵀ)/2h (world frame) and ω̇ ≈ (ω(t+h) − ω(t−h))/2h."""
    Rp, wp, _ = rot.sample(t + h)
    Rm, wm, _ = rot.sample(t - h)
    return pin.log3(Rp @ Rm.T) / (2 * h), (wp - wm) / (2 * h)


# ---- positions ---------------------------------------------------------------------------

def test_circle_has_its_radius_in_its_plane_after_the_ramp():
    c = build_trajectory({"type": "circle", "radius": 0.05, "plane": "yz", "frequency": 0.5, "ramp": 0.2}, 3,
                         dt=DT)
    for t in np.linspace(0.2, 3.0, 57):
        x, dx, ddx = c.sample(t)
        assert x[0] == 0.0 and abs(np.hypot(x[1], x[2]) - 0.05) < 1e-12
        assert abs(np.linalg.norm(dx) - 0.05 * 2 * np.pi * 0.5) < 1e-12          # |v| = r ω
        assert np.allclose(ddx, -(2 * np.pi * 0.5) ** 2 * x, atol=1e-12)         # centripetal
    # the same circle as a sinusoid with per-axis phases
    s = build_trajectory({"type": "sinusoid", "amplitude": [0, 0.05, 0.05], "phase": [0, np.pi / 2, 0],
                          "frequency": 0.5, "ramp": 0.2}, 3, dt=DT)
    for t in (0.05, 0.7, 1.9):
        assert all(np.allclose(a, b) for a, b in zip(c.sample(t), s.sample(t)))


@pytest.mark.parametrize("spec", [
    {"type": "sinusoid", "amplitude": [0.02, 0.05, 0.01], "phase": [0.3, 1.2, -2.0], "frequency": 0.8, "ramp": 0.5},
    {"type": "circle", "radius": 0.04, "plane": "xz", "frequency": 1.0, "phase": 0.4},
    {"type": "spline", "waypoints": [[0, 0, 0, 0], [0.4, 0.05, 0, 0.02], [0.9, 0.03, 0.04, 0.0],
                                     [1.5, 0.0, 0.0, 0.05]]},
])
def test_velocity_and_acceleration_match_finite_differences(spec):
    traj = build_trajectory(spec, 3, dt=DT)
    for t in np.linspace(0.013, 1.6, 40):
        v_fd, a_fd = _fd(traj, t)
        _, dx, ddx = traj.sample(t)
        assert np.allclose(dx, v_fd, atol=1e-7) and np.allclose(ddx, a_fd, atol=1e-5), t


def test_spline_passes_the_waypoints_with_continuous_velocity_and_acceleration():
    T = np.array([0.0, 0.4, 0.9, 1.5])
    P = np.array([[0, 0, 0], [0.05, 0, 0.02], [0.03, 0.04, 0.0], [0.0, 0.0, 0.05]])
    sp, mj = Spline(T, P), Waypoints(T, P)
    eps = 1e-9
    for k, t in enumerate(T):
        assert np.allclose(sp.sample(t)[0], P[k], atol=1e-15)
    for t in T[1:-1]:
        (xl, vl, al), (xr, vr, ar) = sp.sample(t - eps), sp.sample(t + eps)
        assert np.allclose(xl, xr, atol=1e-9) and np.allclose(vl, vr, atol=1e-7) and np.allclose(al, ar, atol=1e-6)
        assert np.linalg.norm(vl) > 1e-3          # moving through the waypoint, not stopping
        assert np.linalg.norm(mj.sample(t - eps)[1]) < 1e-6     # the rest-to-rest one stops there
    for t in (T[0], T[-1]):                       # clamped: at rest at both ends
        assert np.allclose(sp.sample(t + (1e-9 if t == T[0] else -1e-9))[1], 0, atol=1e-6)


# ---- orientations ------------------------------------------------------------------------

ROTATIONS = [
    {"axis": [0.2, 0.0, 1.0], "amplitude": 0.4, "frequency": 0.7, "phase": 0.3, "ramp": 0.3},
    {"type": "spline", "times": [0, 0.5, 1.1, 1.6],
     "rotations": [[0, 0, 0], [0.3, -0.2, 0.1], [0.1, 0.4, -0.5], [[0, -1, 0], [1, 0, 0], [0, 0, 1]]]},
    {"type": "waypoints", "waypoints": [[0, 0, 0, 0], [0.6, 0.2, 0.5, -0.1], [1.4, -0.3, 0.1, 0.6]]},
]


@pytest.mark.parametrize("spec", ROTATIONS)
def test_angular_velocity_and_acceleration_are_those_of_R(spec):
    rot, _ = build_rotation(spec, "rotation", DT)
    for t in np.linspace(0.021, 1.59, 37):
        R, w, dw = rot.sample(t)
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-12) and np.linalg.det(R) > 0
        w_fd, dw_fd = _so3_fd(rot, t)
        assert np.allclose(w, w_fd, atol=1e-6), (t, w, w_fd)
        assert np.allclose(dw, dw_fd, atol=1e-4), (t, dw, dw_fd)


def test_rotation_spline_interpolates_and_keeps_omega_continuous():
    spec = ROTATIONS[1]
    rot, _ = build_rotation(spec, "rotation", DT)
    for t, r in zip(spec["times"][:3], spec["rotations"][:3]):
        assert np.allclose(rot.sample(t)[0], pin.exp3(np.array(r, float)), atol=1e-12)
    for t in spec["times"][1:-1]:
        (_, wl, al), (_, wr, ar) = rot.sample(t - 1e-9), rot.sample(t + 1e-9)
        assert np.linalg.norm(wl) > 1e-2 and np.allclose(wl, wr, atol=1e-7) and np.allclose(al, ar, atol=1e-5)


def test_frame_reference_rotates_relative_to_the_start_orientation():
    traj = build_trajectory({"type": "circle", "radius": 0.03, "plane": "xy", "frequency": 0.5, "ramp": 0.0,
                             "rotation": {"axis": [0, 0, 1], "amplitude": 0.3, "frequency": 0.5, "ramp": 0}}, 3,
                            dt=DT, orientation=True)
    M0 = pin.SE3(pin.exp3(np.array([0.1, -0.4, 0.2])), np.array([0.3, -0.2, 0.9]))
    M, twist, acc = frame_reference(traj, False, M0, 0.5)            # θ = 0.3 sin(π/2) = 0.3 rad
    assert np.allclose(M.rotation, pin.exp3(np.array([0, 0, 0.3])) @ M0.rotation)
    assert np.allclose(M.translation, M0.translation + [0.0, 0.03, 0.0], atol=1e-12)
    assert np.allclose(twist[3:], 0, atol=1e-12) and np.allclose(acc[3:], [0, 0, -0.3 * np.pi**2])


# ---- validation ---------------------------------------------------------------------------

@pytest.mark.parametrize("spec, orientation, key, words", [
    ({"type": "sinusoid", "amplitude": [0, 0.1, 0], "frequency": 1, "phase": [0, float("nan"), 0]}, False,
     "tr.phase[1]", "NaN"),
    ({"type": "sinusoid", "amplitude": [0, 0.1, 0], "frequency": 1, "phase": [0, 1]}, False, "tr.phase", "3"),
    ({"type": "circle", "radius": 0.05, "plane": "xw", "frequency": 1}, False, "tr.plane", "xw"),
    ({"type": "circle", "radius": -1, "plane": "xy", "frequency": 1}, False, "tr.radius", "(0, 1000]"),
    ({"type": "circle", "radius": 0.1, "plane": "xy", "frequency": 600}, False, "tr.frequency", "Nyquist"),
    ({"type": "spline", "waypoints": [[0, 0, 0, 0], [0.0005, 1, 0, 0]]}, False, "tr.waypoints[1][0]", "dt"),
    ({"type": "spline", "times": [0, 1], "points": [[0, 0, 0], [0, float("nan"), 0]]}, False, "tr.points[1][1]",
     "NaN"),
    ({"type": "spline", "times": [0, 1], "points": [[0, 0, 0]] * 2, "waypoints": []}, False, "tr.waypoints",
     "either"),
    ({"rotation": {"axis": [0, 0, 1], "amplitude": 0.1, "frequency": 1}}, False, "tr.rotation", "orientation"),
    ({"rotation": {"axis": [0, 0, 0], "amplitude": 0.1, "frequency": 1}}, True, "tr.rotation.axis", "non-zero"),
    ({"rotation": {"axis": [0, 0, 1], "amplitude": 4.0, "frequency": 1}}, True, "tr.rotation.amplitude", "rad"),
    ({"rotation": {"axis": [0, 0, 1], "amplitude": 0.1, "frequncy": 1}}, True, "tr.rotation.frequncy",
     "did you mean 'frequency'"),
    ({"rotation": {"type": "spline", "times": [0, 1], "rotations": [[0, 0, 0], np.diag([1, 1, -1]).tolist()]}},
     True, "tr.rotation.rotations[1]", "rotation matrix"),
    ({"rotation": {"type": "spline", "times": [0, 1], "rotations": [[0, 0, 0], np.diag([1, 1, 2]).tolist()]}},
     True, "tr.rotation.rotations[1][2][2]", "[-1, 1]"),
])
def test_bad_keys_are_refused_with_their_path(spec, orientation, key, words):
    with pytest.raises(ConfigError) as info:
        build_trajectory(spec, 3, "tr", dt=DT, orientation=orientation)
    assert info.value.key == key and words in str(info.value), str(info.value)


# ---- scenarios: events: add with a target; closed loop ------------------------------------

def _scenario(tmp_path, body: str):
    from wbc.scenario.loader import load_config

    p = tmp_path / "s.yaml"
    p.write_text(textwrap.dedent(body))
    return load_config(p)


STACK = """\
    name: traj_test
    robot: talos
    solver: {type: hqp, backend: daqp}
    control: {dt: 0.001}
    duration: 0.5
    environment: [{type: ground, mu: 0.8}]
    stack:
      - - {type: joint_limits}
        - {type: torque_limits}
        - {type: contact, contact: left_foot}
        - {type: contact, contact: right_foot}
      - - {type: com, kp: 60.0, axes: xy}
      - - type: frame
          frame: right_hand
          name: rh
          kp: 400.0
          trajectory:
            type: circle
            radius: 0.03
            plane: yz
            frequency: 1.0
            ramp: 0.1
            rotation: {axis: [1, 0, 0], amplitude: 0.15, frequency: 1.0, ramp: 0.1}
      - - {type: frame, frame: torso, kp: 20.0, mask: orientation}
        - {type: posture, kp: 5.0, weight: 0.1}
"""


def test_talos_hand_tracks_a_circle_and_a_rotation_in_closed_loop(tmp_path):
    from wbc.runner.loop import run

    sc = _scenario(tmp_path, STACK)
    task = sc.stack["rh"]
    pos_err, rot_err, rot_ref = [], [], []
    R0 = []

    def watch(t, sim, sol):
        e = task.full_error(sc.robot)
        pos_err.append(np.linalg.norm(e[:3]))
        rot_err.append(np.linalg.norm(e[3:]))
        if not R0:
            R0.append(task.target.rotation.copy())
        rot_ref.append(np.linalg.norm(pin.log3(task.target.rotation @ R0[0].T)))

    m = run(sc, duration=0.5, callback=watch)
    assert not m.get("fell", False)
    assert max(rot_ref) > 0.14                   # the reference does rotate (0.15 rad amplitude)
    # tracking within 3 mm (10 % of the 3 cm radius) and 0.015 rad (10 % of the amplitude)
    assert max(pos_err) < 3e-3, max(pos_err)
    assert max(rot_err) < 0.015, max(rot_err)


def test_events_add_keeps_its_target(tmp_path):
    from wbc.runner.loop import run

    head = STACK.partition("      - - type: frame\n")[0]
    body = head + ("      - - {type: frame, frame: torso, kp: 20.0, mask: orientation}\n"
                   "        - {type: posture, kp: 5.0, weight: 0.1}\n"
                   "    events:\n"
                   "      - {time: 0.1, level: 2, add: {type: frame, frame: left_hand, name: lh, mask: position,\n"
                   "                                    kp: 100.0, target: [0.25, 0.35, 0.95]}}\n")
    sc = _scenario(tmp_path, body)
    seen = []
    run(sc, duration=0.15, callback=lambda t, sim, sol: seen.append(sc.stack["lh"].target.translation.copy())
        if "lh" in sc.stack else None)
    assert seen and np.allclose(seen[0], [0.25, 0.35, 0.95]) and np.allclose(seen[-1], [0.25, 0.35, 0.95])
