"""The benchmark harness (benchmarks/harness/, run by `wbc bench`) in a tiny mode: the
structure of what it reports, and that what it times is what the controller computes
(back-ends agree, instrumentation and the simulator's timer change nothing). Nothing here
asserts a wall-clock time."""

from __future__ import annotations

import argparse
import json
import warnings

import numpy as np
import pinocchio as pin
import pytest

import wbc
from benchmarks.harness import cli, options, report, scaling, timing
from benchmarks.harness.stacks import talos_stack
from benchmarks.harness.trajectory import DT, moving_targets
from wbc.cli import bench


def test_tiny_run_reports_every_section():
    res = cli.run(cycles=20, warmup=5, backends=["daqp"], robots=("talos",), floor=True, peer=True,
                    scaling_nv=(12, 18), scaling_levels=(1, 2), scaling_cycles=5, scaling_warmup=2, svd_reps=0)
    json.dumps(res)                                         # serialisable as --json writes it
    m = res["machine"]
    for key in ("cpu", "cores", "python", "numpy", "pin"):
        assert m[key]
    cases = res["cases"]
    assert [(c["solver"], c["backend"]) for c in cases] == [("projection", None), ("hqp", "daqp"), ("weighted", "daqp")]
    for c in cases:
        assert "error" not in c, c
        assert (c["robot"], c["levels"], c["nv"], c["cycles"]) == ("talos", 5, 38, 20)
        assert 0 < c["median_ms"] <= c["p99_ms"] <= c["max_ms"]
        assert set(c["phases"]) == {"update", "rows", "solve", "finish", "other"}
        assert all(c["phases_mean"][p] > 0 for p in timing.PHASES)
        # the phases are timed inside the cycle of their (instrumented) pass: together they
        # never exceed it
        assert sum(c["phases_mean"][p] for p in timing.PHASES) <= c["instrumented_mean_ms"]
        assert sum(c["statuses"].values()) == 20
        assert c["final_state_finite"]
    fl = res["floor_ms"]
    assert fl["talos"] == pytest.approx(fl["talos_parts"]["sum"])
    assert fl["talos_parts"]["qp_size"] == {"variables": 50, "equalities": 18, "inequalities": 100}
    assert set(fl["talos_parts"]["daqp_exitflags"]) <= {"1", "2"}   # every floor QP solved
    assert set(res["placo_ms"]) == {"talos", "talos_dynamics", "talos_kinematics"}
    assert res["placo_ms"]["talos"] == res["placo_ms"]["talos_dynamics"]
    for key in ("talos_dynamics", "talos_kinematics"):          # a number, or reported missing
        val = res["placo_ms"][key]
        assert (val is not None and val > 0) or "missing" in res["placo"][key]
    sl = res["sim_loop"]                                        # the closed loop, both solvers
    for solver in ("hqp", "projection"):
        assert sl[solver]["real_time_factor"] > 0 and not sl[solver]["fell"]
        assert 0 < sl[solver]["controller_median_ms"] and 0 < sl[solver]["simulator_median_ms"]
    assert all(c["diagnostics_ms"] > 0 for c in cases)          # diagnostics timed apart, on demand
    sc = res["scaling"]
    assert [(p["nv"], p["solver"]) for p in sc["nv"]["points"]] == [(12, "hqp"), (12, "projection"),
                                                                   (18, "hqp"), (18, "projection")]
    assert [p["levels"] for p in sc["levels"]["points"]] == [1, 1, 2, 2]
    for key in ("nv_hqp", "nv_projection", "levels_hqp", "levels_projection"):
        assert np.isfinite(sc["exponents"][key])
    md = report.results_markdown(dict(res, command="wbc bench --test"))
    assert "| talos | hqp | daqp | 5 | 38 |" in md and "wbc bench --test" in md


def _drive(robot, controllers, cycles: int):
    """Step every controller through the same states (the first controller's q̈ moves the
    state) and targets; return each one's solution at the last state."""
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for k in range(cycles):
            sols = []
            for ctrl, set_targets in controllers:
                set_targets(k * DT)
                sols.append(ctrl.solve(q, v))
            v = v + sols[0].qdd * DT
            q = pin.integrate(robot.model, q, v * DT)
    return sols


def _controller(robot, solver, backend):
    stack = talos_stack()
    ctrl = wbc.Controller(robot, stack, solver=solver, backend=backend)
    robot.update(robot.q_default, np.zeros(robot.nv))
    return ctrl, moving_targets(robot, stack)


def test_hqp_backends_agree_on_the_benchmark_trajectory(talos):
    """At one state of the benchmark trajectory (QPs active), every back-end's hqp q̈ (each
    QP solved by the back-end) is the daqp one within 1e-6 relative, and so is the default
    solver's, whose QPs are solved from a certified active set where one is."""
    ctrls = [_controller(talos, "hqp", be) for be in options.BACKENDS]
    for ctrl, _ in ctrls:
        ctrl.solver.certify = False
    ctrls.append(_controller(talos, "hqp", "daqp"))
    sols = _drive(talos, ctrls, 120)
    ref = sols[0].qdd
    assert np.linalg.norm(ref) > 1.0 and sols[0].qp_count >= 1
    assert any(d.qp_status == "certified" for d in sols[-1].diagnostics)
    for be, sol in zip(options.BACKENDS + ("certified",), sols):
        assert sol.status == "ok", (be, sol.message)
        assert np.linalg.norm(sol.qdd - ref) <= 1e-6 * np.linalg.norm(ref), be


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_phase_timers_change_nothing(talos, solver):
    """The wrapped (timed) controller returns exactly what the plain one does."""
    plain, timed = _controller(talos, solver, "daqp"), _controller(talos, solver, "daqp")
    timer = timing.PhaseTimer()
    timer.instrument(timed[0])
    try:
        a, b = _drive(talos, [plain, timed], 30)
    finally:
        timer.restore()
    assert np.array_equal(a.qdd, b.qdd) and np.array_equal(a.tau, b.tau)
    assert all(timer.acc[p] > 0 for p in timing.PHASES)
    assert "update" not in vars(talos) and "_finish" not in vars(timed[0])    # restored


def test_bench_subcommand_parses():
    parser = argparse.ArgumentParser()
    bench.add_parser(parser.add_subparsers(dest="cmd"))
    a = parser.parse_args(["bench", "--quick", "--backends", "daqp,osqp", "--cycles", "50", "--json", "x.json"])
    assert a.fn is bench._cmd_bench and a.quick and a.cycles == 50 and a.json == "x.json"
    assert cli.backends_of(a.backends) == ["daqp", "osqp"]
    d = parser.parse_args(["bench"])
    assert cli.backends_of(d.backends) == list(options.BACKENDS) and d.cycles is None and not d.quick
    assert cli.command(d) == "wbc bench"


def test_loglog_exponent():
    x = np.array([12, 24, 48, 96])
    assert scaling.loglog_exponent(x, 3.0 * x**1.5) == pytest.approx(1.5)


def test_timed_simulator_changes_nothing_and_times_every_step():
    """The closed loop driven through the bench's simulator timer (a wrapper object, the
    simulator itself untouched) gives the metrics of the plain run, bit for bit, and one
    step time per control cycle."""
    from benchmarks.harness.closed_loop import TimedSimulator
    from wbc.runner.loop import run as run_scenario
    from wbc.scenario.examples import SCENARIOS_DIR
    from wbc.scenario.loader import load_config

    path = SCENARIOS_DIR / "talos_balance.yaml"
    timed: list[TimedSimulator] = []
    plain = run_scenario(load_config(path), duration=0.05)
    wrapped = run_scenario(load_config(path), duration=0.05, wrap_simulator=lambda sim: timed.append(TimedSimulator(sim))
                           or timed[-1])
    for m in (plain, wrapped):
        for key in ("cycle_time", "real_time_factor"):          # wall-clock figures
            m.pop(key)
    assert json.dumps(plain, sort_keys=True) == json.dumps(wrapped, sort_keys=True)
    assert len(timed) == 1 and len(timed[0].step_times) == round(0.05 / 1e-3)
    assert all(t > 0 for t in timed[0].step_times)


def test_bench_without_its_harness_exits_2_and_says_where_to_get_it(tmp_path):
    """An installed wbc without the source tree (a copy of the package alone, run from an
    empty directory): `wbc bench` prints one error naming benchmarks/harness/ and where to
    get it, and exits 2; its --help still works."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    site = tmp_path / "site"
    shutil.copytree(Path(wbc.__file__).parent, site / "wbc", ignore=shutil.ignore_patterns("__pycache__", "*.nb?"))
    work = tmp_path / "work"
    work.mkdir()
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(site), "HOME": str(tmp_path)}

    def wbc_cmd(*argv):
        return subprocess.run([sys.executable, "-m", "wbc.cli.main", *argv], cwd=work, env=env, capture_output=True,
                              text=True, timeout=120)

    out = wbc_cmd("bench", "--quick")
    assert out.returncode == 2, out.stderr
    err = out.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: wbc bench needs the benchmark harness, benchmarks/harness/")
    assert "source" in err[0] and str(work) in err[0] and "Traceback" not in out.stderr
    assert wbc_cmd("bench", "--help").returncode == 0
