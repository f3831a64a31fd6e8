"""Contact switching: a foot lifts off and lands again without a torque jump.

The contact's normal force is ramped to zero before release (and up from zero at
touch-down). Measured against the same step made with instantaneous switches,
the per-cycle torque change through the switches is more than 10 times smaller,
and of the order of what the smooth weight shift itself produces."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from wbc.runner.loop import run
from wbc.scenario.loader import load_config

STEP = Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios" / "talos_step.yaml"


def _run_step(path, duration):
    sc = load_config(path)
    R = sc.robot
    fid = R.model.getFrameId("right_sole_link")
    rec = []

    def cb(t, sim, sol):
        pin.framesForwardKinematics(R.model, sim.data, sim.q)
        rec.append((t, sim.data.oMf[fid].translation.copy(), sol.tau.copy()))

    m = run(sc, solver="hqp", duration=duration, callback=cb)
    T = np.array([r[0] for r in rec])
    P = np.array([r[1] for r in rec])
    jumps = np.abs(np.diff(np.array([r[2] for r in rec]), axis=0)).max(axis=1)
    return m, T[1:], P, jumps


def _window(T, jumps, a, b):
    return jumps[(T >= a) & (T < b)].max()


def test_step_lifts_off_and_lands_with_continuous_torque(tmp_path):
    m, T, P, jumps = _run_step(STEP, 3.0)
    assert not m["fell"] and m["solver_failures"] == 0
    assert P[:, 2].max() > 0.045                       # the foot was lifted ~5 cm
    assert abs((P[-1, 0] - P[0, 0]) - 0.10) < 0.01     # and put down 10 cm forward
    assert abs(P[-1, 2]) < 1e-3
    assert m["contacts"]["left_foot"]["slip"] < 1e-3 and not m["contacts"]["left_foot"]["lifted"]
    release, touchdown = _window(T, jumps, 1.45, 1.80), _window(T, jumps, 2.55, 2.90)

    instant = tmp_path / "step_instant.yaml"
    instant.write_text(STEP.read_text().replace("release: right_foot_contact, duration: 0.2",
                                                "release: right_foot_contact, duration: 0.001")
                       .replace("level: 0, duration: 0.2}", "level: 0, duration: 0.001}"))
    _, Ti, _, jumps_i = _run_step(instant, 2.8)
    release_i, touchdown_i = _window(Ti, jumps_i, 1.45, 1.80), _window(Ti, jumps_i, 2.55, 2.80)
    print(f"max per-cycle torque change: ramped release {release:.2f}, touch-down {touchdown:.2f} N·m; "
          f"instantaneous {release_i:.2f}, {touchdown_i:.2f} N·m")
    assert release < 0.1 * release_i and touchdown < 0.1 * touchdown_i
