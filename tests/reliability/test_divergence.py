"""A simulation that diverges (a corrupted state, a huge push) is detected after the step
that did it, in both simulators: the run stops with its reason and the metrics of the
cycles before it (exit status 1 from `wbc run`, no traceback), never a NaN torque sent."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wbc.cli.main import main
from wbc.controller.faults import DIVERGED_SPEED, diverged
from wbc.runner.loop import run

from .conftest import panda_scenario

try:
    import mujoco  # noqa: F401
    _MUJOCO = True
except ImportError:        # the peer environment (pinocchio 3.8) installs no MuJoCo
    _MUJOCO = False
SIMULATORS = ["pinocchio", pytest.param("mujoco", marks=pytest.mark.skipif(not _MUJOCO, reason="needs mujoco"))]
T_CORRUPT = 0.05


class Corrupt:
    """A runner callback that corrupts the simulated velocity once, at ``T_CORRUPT``, and
    checks every torque sent before and after."""

    def __init__(self, how: str, tau_max) -> None:
        self.how, self.tau_max, self.sent = how, tau_max, 0

    def __call__(self, t, sim, sol) -> None:
        assert np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= self.tau_max)
        self.sent += 1
        if abs(t - T_CORRUPT) < 1e-9:
            v = sim.v.copy()
            if self.how == "nan":
                v[2] = np.nan
            else:
                v[:] = 1e5
            if hasattr(sim, "set_state"):       # MuJoCo: its state is MjData's
                sim.set_state(sim.q, v)
            else:
                sim.v = v


@pytest.mark.parametrize("simulator", SIMULATORS)
@pytest.mark.parametrize("how", ["nan", "speed"])
def test_a_corrupted_state_stops_the_run_with_partial_metrics(tmp_path, panda, simulator, how):
    sc = panda_scenario(tmp_path, duration=0.3)
    cb = Corrupt(how, panda.tau_max[panda.actuated_idx])
    m = run(sc, simulator=simulator, callback=cb)
    stop = m["stopped"]
    assert stop is not None and stop["by"] == "simulator" and "simulation diverged" in stop["reason"]
    # detected after the first step from the corrupted state (MuJoCo resets a bad state itself:
    # that reset is what is reported there)
    n = round(T_CORRUPT / sc.dt) + 1
    assert stop["time"] == pytest.approx((n + 1) * sc.dt) and m["duration"] == pytest.approx((n + 1) * sc.dt)
    assert cb.sent == n                 # the callback never saw the diverged step
    assert m["violations"]["torque"] == 0 and m["tau_ratio_max"] <= 1.0
    if how == "nan":                    # the controller saw it first: a held state fault
        assert m["faults"]["state_faults"] == 1
    json.dumps(m, allow_nan=False)      # the partial metrics are plain JSON


@pytest.mark.parametrize("simulator", SIMULATORS)
def test_a_huge_push_is_a_divergence_and_wbc_run_exits_1(tmp_path, capsys, simulator):
    path = tmp_path / "push.yaml"
    panda_scenario(tmp_path, duration=0.3)            # writes panda_arm.yaml
    doc = (tmp_path / "panda_arm.yaml").read_text()
    path.write_text(doc + "pushes:\n  - {frame: hand, force: [100000.0, 0.0, 0.0], start: 0.05, duration: 0.1}\n")
    out = tmp_path / "m.json"
    assert main(["run", str(path), "--headless", "--sim", simulator, "--metrics", str(out)]) == 1
    err = capsys.readouterr().err
    assert "wbc: run stopped at t = " in err and "by the simulator: simulation diverged" in err
    assert "Traceback" not in err and "internal error" not in err
    m = json.loads(out.read_text())
    assert m["stopped"]["by"] == "simulator" and 0.05 < m["duration"] < 0.15
    assert m["violations"]["torque"] == 0


def test_diverged_names_the_cause():
    q, v = np.zeros(7), np.zeros(7)
    assert diverged(q, v) == ""
    v[3] = 2 * DIVERGED_SPEED
    assert "speed" in diverged(q, v) and "dof 3" in diverged(q, v)
    v[3] = np.inf
    assert "not finite" in diverged(q, v)
    q[0], v[3] = 1e9, 0.0
    assert "coordinate" in diverged(q, v)


def test_a_sweep_case_whose_simulation_diverged_does_not_survive(tmp_path):
    """A sweep's worker records a run stopped early as ``fell`` (it ran, with metrics, and
    never survives), not ``ok``."""
    import yaml

    from wbc.sweep.cases import static_cases
    from wbc.sweep.criteria import survived
    from wbc.sweep.spec import load_spec
    from wbc.sweep.worker import execute

    panda_scenario(tmp_path, duration=0.15, pushes=[{"frame": "hand", "force": [1.0, 0.0, 0.0],
                                                      "start": 0.05, "duration": 0.1}])
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": str(tmp_path / "panda_arm.yaml"),
                                    "axes": {"pushes[0].force@magnitude": [1.0, 1e5]}}))
    sp = load_spec(spec)
    rows = [execute(c.payload()) for c in static_cases(sp)]
    gentle, huge = sorted(rows, key=lambda r: r["metrics"]["duration"], reverse=True)
    assert gentle["status"] == "ok" and survived(gentle | gentle["metrics"], sp.survive)
    assert huge["status"] == "fell" and huge["metrics"]["stopped.by"] == "simulator"
    assert not survived(huge | huge["metrics"], sp.survive)
