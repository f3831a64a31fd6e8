"""A relaxed level 0 keeps its contact cones (wbc.solvers.hqp's module doc): the go2 with
its calves at 0 rad (outside their range [−2.72, −0.84] rad: the start of a `wbc robot init`
go2 at its zero posture before init clamped such joints into their range) and moving further
out cannot meet its joint-limit box with its torques: level 0 is relaxed, the slack goes to
the joint-limit and torque rows, and every
planned contact force stays inside its own cone (f − f₀ a non-negative combination of the
cone's generators), with hqp and weighted (which shares the hqp's level 0). Relaxing every
row as one planned feet pulling on the ground."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import nnls

import wbc
from wbc.problem.rows import Level
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture, TorqueLimits

FEET = ("fl_foot", "fr_foot", "rl_foot", "rr_foot")


@pytest.fixture(scope="module")
def go2() -> wbc.RobotModel:
    return wbc.load_robot("go2")


def _states(robot, n):
    m = robot.model
    rng = np.random.default_rng(0)
    calves = [j for j in range(2, m.njoints) if "calf" in m.names[j]]
    for _ in range(n):
        q, v = robot.q_default.copy(), np.zeros(robot.nv)
        for j in calves:
            q[m.joints[j].idx_q] = rng.uniform(-0.1, 0.0)
            v[m.joints[j].idx_v] = rng.uniform(0.5, 3.0)
        yield q, v


def _outside(sol, contacts) -> int:
    n = 0
    for c in contacts:
        f0, V = c.generators()
        f = sol.forces[c.name]
        n += nnls(V, f - f0)[1] > 1e-6 * (1.0 + np.linalg.norm(f))
    return n


def _relaxed_runs(go2, solver):
    """(solution, contacts) per state, the standing stack of benchmarks/singularities.py."""
    for q, v in _states(go2, 5):
        cs = [Contact(f) for f in FEET]
        stack = wbc.Stack([[JointLimits(), TorqueLimits(), *cs], [CoM()], [Frame("base", mask="orientation")],
                           [Posture()]])
        ctrl = wbc.Controller(go2, stack, solver=solver)
        yield ctrl.solve(q, v), cs


@pytest.mark.parametrize("solver", ["hqp", "weighted"])
def test_a_relaxed_level_0_plans_no_force_outside_its_cone(go2, solver):
    relaxed = 0
    for sol, cs in _relaxed_runs(go2, solver):
        assert sol.ok and np.all(np.isfinite(sol.tau))
        assert _outside(sol, cs) == 0
        if sol.relaxed:
            relaxed += 1
            assert "relaxed" in sol.conditions
            assert not any(c.name in sol.diagnostics[0].violations for c in cs)      # slack elsewhere
            assert "joint_limits" in sol.diagnostics[0].violations
    assert relaxed >= 4


def test_relaxing_every_row_alike_pulls_on_the_ground(go2, monkeypatch):
    """The same states with no row kept hard (the rule before): forces outside the cones,
    so the test above can tell."""
    monkeypatch.setattr(Level, "contact_rows", lambda self: np.zeros(0, dtype=np.int64))
    assert sum(_outside(sol, cs) > 0 for sol, cs in _relaxed_runs(go2, "hqp")) >= 3


def standing(robot) -> dict:
    """The bundled go2_stand scenario with ``robot`` (a name or a YAML path), standing still
    (its CoM target held where it starts, no sway)."""
    doc = yaml.safe_load((Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios" / "go2_stand.yaml")
                         .read_text())
    doc.update(name="go2_zero", robot=str(robot), description="The Go2 standing still.")
    doc["stack"][1] = [{"type": "com"}]
    return doc


@pytest.mark.parametrize("duration", [pytest.param(1.5, marks=pytest.mark.slow), 0.4])
@pytest.mark.parametrize("solver", ["hqp", "weighted"])
def test_the_go2_of_robot_init_stands_in_mujoco(tmp_path, capsys, go2, solver, duration):
    """The go2 of `wbc robot init` at its zero posture (calves at 0 rad, past their range)
    standing in MuJoCo: with every row relaxed alike it planned negative normal forces from
    cycle 7 and fell at 0.18 s; now it stands and no solution reported ok or saturated plans
    a force outside its cone (short default 0.4 s, 1.5 s slow)."""
    pytest.importorskip("mujoco")
    from wbc.cli.main import main
    from wbc.runner.loop import ScenarioRun
    from wbc.scenario.loader import load_config

    robot_yaml = tmp_path / "go2_init.yaml"
    assert main(["robot", "init", str(go2.urdf_path), "-o", str(robot_yaml)]) == 0
    capsys.readouterr()
    # init now puts the calves inside their range: without its default_posture line the robot
    # is at the zero configuration again (the start this test is about)
    text = robot_yaml.read_text()
    assert "default_posture:" in text
    robot_yaml.write_text("".join(ln for ln in text.splitlines(keepends=True) if not ln.startswith("default_posture:")))
    path = tmp_path / "go2_zero.yaml"
    path.write_text(yaml.safe_dump(standing(robot_yaml)))
    r = ScenarioRun(load_config(path), solver=solver, simulator="mujoco", progress=False, duration=duration)
    contacts = [t for t in r.stack if t.kind == "contact"]
    relaxed = 0
    for k in range(r.n):
        assert r.cycle(k), f"stopped at cycle {k}"
        sol = r.last_sol
        relaxed += sol.relaxed
        if sol.status in ("ok", "saturated"):
            assert _outside(sol, contacts) == 0, k
    assert not r.metrics()["fell"] and relaxed > 0
