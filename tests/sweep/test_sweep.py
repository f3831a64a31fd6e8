"""`wbc sweep`: key paths, case hashes, bisection, the results store and resume, the
executors (local pool, Ray, a simulated two-node Ray cluster: the same rows), crash and
time-out isolation, model perturbations through the runner, `--validate` errors.

Every simulated case is a 0.25 s run of talos_push with the push at 0.05 s."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import random
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

from wbc.cli.main import main as wbc_main
from wbc.errors import ConfigError
from wbc.sweep import keypath
from wbc.sweep.axes import Axis
from wbc.sweep.bisect import Bisection
from wbc.sweep.cases import case_hash, make_case, static_cases
from wbc.sweep.engine import run_sweep
from wbc.sweep.jobs import Outcome
from wbc.sweep.perturb import Perturbation
from wbc.sweep.spec import load_spec
from wbc.sweep.store import ResultStore, cell, parse_cell

SHORT = {"duration": 0.25, "pushes[0].start": 0.05}


def write_spec(tmp_path: Path, name: str = "s.yaml", **spec) -> Path:
    spec.setdefault("base", "talos_push")
    spec.setdefault("set", dict(SHORT))
    p = tmp_path / name
    p.write_text(yaml.safe_dump(spec, sort_keys=False))
    return p


def comparable(records: list[dict]) -> dict[str, dict]:
    """Rows by hash, without the wall time (the one column that may differ between runs)."""
    return {r["hash"]: {k: v for k, v in r.items() if k != "wall_s"} for r in records}


@pytest.fixture(scope="module", autouse=True)
def warm_kernels():
    """Load (or compile, once, into numba's disk cache) the kernels of both solvers before
    worker processes need them, so that no case spends its time-out compiling."""
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    for solver in ("hqp", "projection"):
        run(load_config("talos_push"), solver=solver, duration=0.005)


# ---------------------------------------------------------------- key paths

def test_key_paths_set_the_scenario_document_like_its_error_messages_name_it():
    doc = yaml.safe_load((Path(__file__).resolve().parents[2] / "wbc/data/scenarios/talos_push.yaml").read_text())
    out = keypath.apply_all(doc, {"stack[1][0].kp": 7.0, "solver.type": "projection", "environment[0].mu": 0.4,
                                  "sensing.noise_q": 1e-3, "pushes[0].force@direction_deg": 90.0,
                                  "pushes[0].force@magnitude": 200.0})
    assert out["stack"][1][0]["kp"] == 7.0 and out["solver"]["type"] == "projection"
    assert out["environment"][0]["mu"] == 0.4 and out["sensing"] == {"noise_q": 1e-3}
    assert out["pushes"][0]["force"] == [0.0, 200.0, 0.0]           # exact zero along the axis
    assert doc["pushes"][0]["force"] == [150.0, 0.0, 0.0]            # the base is untouched
    # a direction alone keeps the base's magnitude, a magnitude alone its direction
    assert keypath.apply_all(doc, {"pushes[0].force@direction_deg": 180.0})["pushes"][0]["force"] == [-150.0, 0.0, 0.0]
    f = keypath.apply_all(doc, {"pushes[0].force@direction_deg": 45.0})["pushes"][0]["force"]
    assert math.hypot(f[0], f[1]) == pytest.approx(150.0) and f[0] == pytest.approx(f[1])
    with pytest.raises(Exception, match=r"pushes has 1 item\(s\): \[2\] does not exist"):
        keypath.assign(doc, "pushes[2].force", [1, 2, 3])
    with pytest.raises(Exception, match="malformed key path"):
        keypath.parse("stack[1]..kp")
    assert keypath.join(keypath.parse("stack[1][0].kp")[0]) == "stack[1][0].kp"


# ---------------------------------------------------------------- cases and hashes

def test_case_hash_is_stable_across_processes_and_follows_the_resolved_case(tmp_path):
    spec = load_spec(write_spec(tmp_path, axes={"solver.type": ["hqp", "projection"],
                                                "pushes[0].force@magnitude": [50.0, 100.0]}))
    cases = static_cases(spec)
    assert len({c.hash for c in cases}) == 4
    c0 = cases[0]
    code = ("import json, sys; from wbc.sweep.cases import case_hash; from wbc.sweep.perturb import Perturbation;"
            "d = json.load(sys.stdin); print(case_hash(d, Perturbation(), 0))")
    other = subprocess.run([sys.executable, "-c", code], input=json.dumps(c0.doc), capture_output=True, text=True,
                           check=True, env={**os.environ, "PYTHONHASHSEED": "123"}).stdout.strip()
    assert other == c0.hash
    # the hash is the resolved case's: the same document reached another way, same hash
    again = make_case(spec, {"pushes[0].force@magnitude": 50.0, "solver.type": "hqp"}, 0, "x")
    assert again.hash == c0.hash
    assert case_hash(c0.doc, Perturbation(mass_scale=1.1), 0) != c0.hash
    assert case_hash(c0.doc, Perturbation(), 1) != c0.hash
    # the robot YAML's content is an input too: the same document with the robot file edited
    # (one gain) is another case, so a resumed sweep does not keep the old file's result
    from wbc.robot.loader import robot_yaml_path

    robot_file = tmp_path / "robot.yaml"
    text = robot_yaml_path(c0.doc["robot"]).read_text()
    robot_file.write_text(text)
    doc = {**c0.doc, "robot": str(robot_file)}
    h1 = case_hash(doc, Perturbation(), 0)
    robot_file.write_text(text + "\n# a comment is the same robot\n")
    assert case_hash(doc, Perturbation(), 0) == h1
    assert "posture: 10.0," in text
    robot_file.write_text(text.replace("posture: 10.0,", "posture: 12.0,"))
    assert case_hash(doc, Perturbation(), 0) != h1


def test_more_random_samples_keep_the_earlier_draws(tmp_path):
    axes = {"environment[0].mu": {"range": [0.4, 1.0]}, "solver.type": ["hqp", "projection"]}
    a = static_cases(load_spec(write_spec(tmp_path, "a.yaml", mode="random", samples=5, axes=axes)))
    b = static_cases(load_spec(write_spec(tmp_path, "b.yaml", mode="random", samples=9, axes=axes)))
    assert len(a) == 10 and len(b) == 18
    assert [c.hash for c in a] == [c.hash for c in b[:10]]
    mus = [c.values["environment[0].mu"] for c in b[::2]]
    assert all(0.4 <= m <= 1.0 for m in mus) and len(set(mus)) == 9
    assert [c.values["solver.type"] for c in b[:2]] == ["hqp", "projection"]   # crossed with the grid


# ---------------------------------------------------------------- bisection

def test_bisection_finds_the_threshold_to_tolerance_from_its_own_outcomes():
    axis = Axis("x", "bisect", lo=0.0, hi=800.0, tol=10.0)
    for thr in (0.0, 3.0, 237.1, 799.0, 900.0):
        b = Bisection(axis)
        while not b.done:
            v = b.next_value()
            b.record(v, v < thr)
        if thr >= 800:
            assert b.outcome == "at_least_hi" and b.limit == 800.0 and len(b.probes) == 1
        elif thr <= 0:
            assert b.outcome == "below_lo" and b.limit is None and len(b.probes) == 2
        else:
            assert b.outcome == "bracketed" and b.lo < thr <= b.hi and b.hi - b.lo <= 10.0
            assert len(b.probes) == 2 + math.ceil(math.log2(800 / 10))


class FakeExecutor:
    """An executor that runs nothing: a case survives when its push is below a threshold
    that depends on the solver and direction; outcomes come back in a shuffled order,
    several at a time."""

    name = "fake"

    def __init__(self, order_seed: int, capacity: int = 3) -> None:
        self.rng, self.capacity, self.q = random.Random(order_seed), capacity, []
        self.runs = 0

    @staticmethod
    def threshold(doc: dict) -> float:
        f = doc["pushes"][0]["force"]
        return 150.0 + 60.0 * math.cos(math.atan2(f[1], f[0])) + (90.0 if doc["solver"]["type"] == "hqp" else 0.0)

    def submit(self, job):
        self.q.append(job)

    def wait(self, timeout):
        self.rng.shuffle(self.q)
        k = self.rng.randint(1, max(1, min(len(self.q), self.capacity)))
        done, self.q = self.q[:k], self.q[k:]
        out = []
        for job in done:
            doc = job.payload["doc"]
            fell = math.hypot(*doc["pushes"][0]["force"][:2]) >= self.threshold(doc)
            out.append(Outcome(job, "fell" if fell else "ok", "", {"fell": fell, "solver_failures": 0}, 0.0))
        self.runs += len(out)
        return out

    def close(self):
        pass


def _bisect_spec(tmp_path, name="b.yaml"):
    return load_spec(write_spec(tmp_path, name, mode="bisect", axes={
        "solver.type": ["hqp", "projection"],
        "pushes[0].force@direction_deg": {"linspace": [0, 270, 4]},
        "pushes[0].force@magnitude": {"bisect": {"lo": 0, "hi": 400, "tol": 5}}}))


def test_bisection_is_deterministic_in_any_completion_order_and_resumes_where_it_stopped(tmp_path):
    spec = _bisect_spec(tmp_path)
    ref = run_sweep(spec, executor=FakeExecutor(0, capacity=1), out_dir=tmp_path / "ref", progress=False)
    probes = [b.probes for _, b in ref.groups]
    for g, b in ref.groups:     # each limit brackets the fake threshold, to tolerance
        doc = make_case(spec, {**g, "pushes[0].force@magnitude": 1.0}, 0, "t").doc
        thr = FakeExecutor.threshold(doc)
        assert b.outcome == "bracketed" and b.lo < thr <= b.hi and b.hi - b.lo <= 5
    for seed in (1, 2):
        other = run_sweep(spec, executor=FakeExecutor(seed, capacity=5), out_dir=tmp_path / f"o{seed}",
                          progress=False)
        assert [b.probes for _, b in other.groups] == probes
        assert comparable(other.records) == comparable(ref.records)
    # interrupted after 7 cases, then finished: only the missing probes run, same result
    first = run_sweep(spec, executor=FakeExecutor(3), out_dir=tmp_path / "cut", stop_after=7, progress=False)
    assert first.stopped and first.ran == 7
    fake = FakeExecutor(4)
    rest = run_sweep(spec, executor=fake, out_dir=tmp_path / "cut", progress=False)
    assert [b.probes for _, b in rest.groups] == probes
    assert rest.skipped == 7 and fake.runs == len({r['hash'] for r in ref.records}) - 7


# ---------------------------------------------------------------- results store

def test_store_cells_round_trip_and_a_cut_last_line_is_dropped(tmp_path):
    for v in (0.1 + 0.2, 1e-300, -0.0, 3, True, False, "hqp", [1.5, 0.0, -2.0], math.inf, None):
        back = parse_cell(cell(v))
        assert back == v and type(back) is type(v) or (v is None and back is None)
    st = ResultStore(tmp_path / "r.csv")
    st.add({"hash": "0123456789012345", "status": "ok", "x": 0.1 + 0.2})
    st.add({"hash": "abcdef0123456789", "status": "fell", "x": 2.0, "y": [1, 2]})     # a new column: rewritten
    with (tmp_path / "r.csv").open("a") as f:
        f.write("fffffffffffffff0,ok,3.0")                                       # killed mid-row
    again = ResultStore(tmp_path / "r.csv")
    assert set(again.rows) == {"0123456789012345", "abcdef0123456789"}             # an all-digit hash stays text
    assert again.rows["0123456789012345"]["x"] == 0.1 + 0.2 and again.rows["abcdef0123456789"]["y"] == [1, 2]
    assert (tmp_path / "r.csv").read_text().endswith("\n")


# ---------------------------------------------------------------- executors agree

def _agreement_spec(tmp_path):
    return load_spec(write_spec(tmp_path, "agree.yaml", axes={
        "solver.type": ["hqp", "projection"], "pushes[0].force@magnitude": [50.0, 150.0, 300.0],
        "environment[0].mu": [0.5, 0.9]}, timeout=240))


@pytest.fixture(scope="module")
def local_rows(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("local")
    res = run_sweep(_agreement_spec(tmp), workers=2, out_dir=tmp / "out", progress=False)
    assert len(res.records) == 12 and res.count("ok") + res.count("fell") == 12
    return comparable(res.records)


def test_a_worker_reuses_its_robot_without_changing_results(tmp_path):
    from wbc.sweep.worker import execute

    cases = static_cases(_agreement_spec(tmp_path))
    a, b = cases[0].payload(), cases[7].payload()
    first = execute(a)
    execute(b)
    assert execute(a)["metrics"] == first["metrics"] and first["status"] == "ok"


needs_ray = pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                               reason="ray is not installed (pip install 'wbc[sweep]')")


def test_without_ray_the_ray_executor_says_how_to_install_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)          # import ray -> ImportError
    path = write_spec(tmp_path, axes={"pushes[0].force@magnitude": [10.0]})
    assert wbc_main(["sweep", str(path), "--executor", "ray", "--out", str(tmp_path / "o")]) == 2
    assert "executor ray needs the ray package" in capsys.readouterr().err
    assert not (tmp_path / "o" / "results.csv").exists()


@needs_ray
def test_ray_gives_the_local_pools_rows(tmp_path, local_rows):
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        res = run_sweep(_agreement_spec(tmp_path), executor="ray", out_dir=tmp_path / "out", progress=False)
    finally:
        ray.shutdown()
    assert res.workers == 2 and comparable(res.records) == local_rows


@pytest.mark.slow          # the one-node Ray test above is its short version
@needs_ray
def test_a_two_node_ray_cluster_gives_the_local_pools_rows(tmp_path, local_rows):
    import ray
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
    try:
        cluster.add_node(num_cpus=1)
        ray.init(address=cluster.address, log_to_driver=False)
        assert sum(n["Alive"] for n in ray.nodes()) == 2
        res = run_sweep(_agreement_spec(tmp_path), executor="ray", out_dir=tmp_path / "out", progress=False)
    finally:
        ray.shutdown()
        cluster.shutdown()
    # two tasks at once on two 1-CPU nodes: the cases ran on both
    assert res.workers == 2 and comparable(res.records) == local_rows


# ---------------------------------------------------------------- isolation, resume

def test_a_case_that_raises_hangs_or_crashes_is_recorded_and_the_sweep_goes_on(tmp_path):
    spec = load_spec(write_spec(tmp_path, axes={"robot": ["talos", "no_such_robot"],
                                                "pushes[0].force@magnitude": [50.0, 100.0, 120.0]},
                                timeout=12, inject={"hang": {"robot": "talos", "pushes[0].force@magnitude": 100.0},
                                                    "crash": {"robot": "no_such_robot",
                                                              "pushes[0].force@magnitude": 100.0}}))
    res = run_sweep(spec, workers=2, out_dir=tmp_path / "out", progress=False)
    by = {(r["robot"], r["pushes[0].force@magnitude"]): r for r in res.records}
    assert by[("talos", 50.0)]["status"] == "ok" and by[("talos", 120.0)]["status"] == "ok"
    assert by[("talos", 100.0)]["status"] == "timeout"
    assert by[("no_such_robot", 50.0)]["status"] == "error" and "no_such_robot" in by[("no_such_robot", 50.0)]["error"]
    assert by[("no_such_robot", 100.0)]["status"] == "failed" and "SIGSEGV" in by[("no_such_robot", 100.0)]["error"]
    assert not any(r["survived"] for r in res.records if r["status"] != "ok")
    assert by[("talos", 120.0)]["tasks.com.rms"] > 0           # the case after the hang ran in a fresh worker


def test_a_killed_sweep_reruns_only_its_missing_cases(tmp_path):
    path = write_spec(tmp_path, axes={"pushes[0].force@magnitude": [20.0, 40.0, 60.0, 80.0],
                                      "environment[0].mu": [0.6, 0.9]})
    csv = tmp_path / "out" / "results.csv"
    proc = subprocess.Popen([sys.executable, "-m", "wbc.cli.main", "sweep", str(path), "--out", str(tmp_path / "out"),
                             "--workers", "1", "--quiet", "--no-plots"], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while proc.poll() is None:
            if csv.exists() and csv.read_text().count("\n") >= 4:       # header + 3 cases
                break
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    before = ResultStore(csv).rows
    assert 3 <= len(before) < 8, "the sweep ended before it was killed"
    res = run_sweep(load_spec(path), workers=1, out_dir=tmp_path / "out", progress=False)
    assert res.skipped == len(before) and res.ran == 8 - len(before)
    after = ResultStore(csv).rows
    assert len(after) == 8 and all(after[h] == row for h, row in before.items())   # kept, not run again


# ---------------------------------------------------------------- model perturbation

def test_mass_perturbation_changes_the_simulated_robot_only(talos):
    model = pin.Model(talos.model)
    Perturbation(mass_scale=1.2, link_scale={"torso_2_link": 0.5})(model)
    j = talos.model.getJointId("torso_2_joint")
    for k in range(1, model.njoints):
        s = 1.2 * (0.5 if k == j else 1.0)
        assert model.inertias[k].mass == pytest.approx(s * talos.model.inertias[k].mass)
        assert np.allclose(model.inertias[k].lever, talos.model.inertias[k].lever)

    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    sc = load_config("talos_push", robot_loader=lambda name: talos)
    seen = {}
    nominal = sum(talos.model.inertias[k].mass for k in range(talos.model.njoints))
    run(sc, duration=0.003, model_perturbation=Perturbation(mass_scale=1.2),
        callback=lambda t, sim, sol: seen.setdefault("sim", sum(sim.model.inertias[k].mass
                                                                for k in range(sim.model.njoints))))
    assert seen["sim"] == pytest.approx(1.2 * nominal)
    assert sum(talos.model.inertias[k].mass for k in range(talos.model.njoints)) == pytest.approx(nominal)


def test_a_heavier_simulated_robot_changes_the_outcome(tmp_path):
    spec = load_spec(write_spec(tmp_path, axes={"model.mass_scale": [1.0, 1.3]}))
    from wbc.sweep.worker import execute

    light, heavy = (execute(c.payload()) for c in static_cases(spec))
    assert light["status"] == heavy["status"] == "ok"
    assert heavy["metrics"]["tasks.com.rms"] > 1.5 * light["metrics"]["tasks.com.rms"]   # model error shows


# ---------------------------------------------------------------- --validate

@pytest.mark.parametrize("axes, extra, where, marker, says", [
    ({"solver.type": ["hqp"], "pushes[2].force@magnitude": [10.0]}, {}, "axes.pushes[2].force@magnitude", "pushes[2]",
     r"pushes has 1 item\(s\): \[2\] does not exist"),
    ({"solver.type": ["hqp", "nope"]}, {}, "axes.solver.type", "solver.type",
     "value 'nope' gives a case that does not build: solver.type: must be one of"),
    ({"model.mass_scale.no_link": [1.1]}, {}, "axes.model.mass_scale.no_link", "no_link",
     "no link or joint 'no_link'"),
    ({"environment[0].mu": {"range": [0.4, 1.0]}}, {}, "axes.environment[0].mu", "environment[0].mu",
     "a range axis does not belong in mode grid"),
    ({"sensing.nois_q": [0.001]}, {}, "axes.sensing.nois_q", "nois_q", "did you mean 'noise_q'"),
    ({"duration": [0.25]}, {"axis": 1}, "axis", "axis:", r"unknown key \(did you mean 'axes'\?\)"),
    ({"pushes[0].force@magnitude": {"bisect": {"lo": 0, "hi": 100, "tol": 0}}}, {"mode": "bisect"},
     "axes.pushes[0].force@magnitude.bisect.tol", "tol:", "must be a number > 0"),
])
def test_validate_names_file_line_and_key_path(tmp_path, capsys, axes, extra, where, marker, says):
    import re

    path = write_spec(tmp_path, axes=axes, **extra)
    assert wbc_main(["sweep", str(path), "--validate"]) == 2
    err = capsys.readouterr().err
    line = next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if marker in ln)
    assert err.startswith(f"error: {path}:{line}: {where}: "), err
    assert re.search(says, err), err


def test_validate_accepts_a_good_spec(tmp_path, capsys):
    path = write_spec(tmp_path, mode="random", samples=3, axes={
        "environment[0].mu": {"range": [0.4, 1.0]}, "model.mass_scale": {"range": [0.8, 1.2]},
        "model.mass_scale.torso_2_link": {"range": [0.8, 1.2]}, "sensing.latency_steps": {"range": [0, 2],
                                                                                          "integer": True},
        "solver.type": {"choices": ["hqp", "projection"]}})
    assert wbc_main(["sweep", str(path), "--validate"]) == 0
    assert "ok (base talos_push, mode random, 5 axes, 3 cases" in capsys.readouterr().out


def test_summary_and_plots_report_each_group(tmp_path):
    from wbc.sweep.plots import plot_all
    from wbc.sweep.summary import markdown

    spec = _bisect_spec(tmp_path)
    res = run_sweep(spec, executor=FakeExecutor(0), out_dir=tmp_path / "b", progress=False)
    text = markdown(res)
    for g, b in res.groups:        # one row per group with its limit and first failure
        assert f"| {g['solver.type']} | {g['pushes[0].force@direction_deg']:g} | {b.lo:.4g} | {b.hi:.4g} |" in text
    assert [p.name for p in plot_all(res)] == ["push_polar.png"]
    grid = load_spec(write_spec(tmp_path, "g.yaml", axes={
        "solver.type": ["hqp", "projection"], "pushes[0].force@direction_deg": [0.0, 90.0, 180.0],
        "pushes[0].force@magnitude": [100.0, 200.0, 300.0]}, summary={"group_by": ["solver.type"]}))
    res = run_sweep(grid, executor=FakeExecutor(1), out_dir=tmp_path / "g", progress=False)
    text = markdown(res)
    n_hqp = sum(r["survived"] for r in res.records if r["solver.type"] == "hqp")
    assert f"| hqp | 9 | {n_hqp} | {n_hqp / 9:.3f} |" in text
    assert {p.name for p in plot_all(res)} == {"push_map.png"}
    assert all(p.stat().st_size > 10_000 for p in res.out_dir.glob("*.png"))


@pytest.mark.parametrize("survive", [{"fell": "maybe"}, {"fell": 0}, {"contacts.*.lifted": "no"},
                                     {"contacts.left_foot.lifted": 1}])
def test_a_boolean_metric_compared_with_anything_but_true_or_false_is_a_config_error(tmp_path, survive):
    """``survive: {fell: maybe}`` used to validate and then fail every case (a string never
    equals a boolean metric): now the spec is refused, naming the key."""
    column = next(iter(survive))
    with pytest.raises(ConfigError, match=rf"survive\.{re.escape(column)}.*true or false"):
        load_spec(write_spec(tmp_path, axes={"solver.type": ["hqp"]}, survive=survive))
    load_spec(write_spec(tmp_path, "ok.yaml", axes={"solver.type": ["hqp"]}, survive={column: False}))
