"""Fuzz: mutated scenario documents either load into a Scenario that runs, or are refused
with a ConfigError naming the file and the key path. Nothing else may come out.

The cases are the bundled scenarios with 1-3 random mutations each (see ``mutations.py``);
every document that loads holds only finite numbers and runs for 3 control cycles (``wbc
run`` makes the same :func:`load_config` call as ``wbc validate``, so "validates" must mean
"runs"). A
second fuzz builds random event timelines (release, touchdown, add, remove at random times
and levels) and runs every one that validates to its end.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wbc.errors import ConfigError, WbcError
from wbc.runner.loop import run
from wbc.scenario.loader import load_config

from .conftest import SLOW_FACTOR, SYNTHETIC, write_yaml
from .mutations import mutated

DEFAULT_CASES = int(__import__("os").environ.get("WBC_FUZZ_N", "1300"))
TIMELINE_CASES = 120


def _numbers(value, where: str):
    """Every number in ``value`` (nested dicts, lists, arrays, SE3s) with its path."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return
    if isinstance(value, pin.SE3):
        value = value.homogeneous
    if isinstance(value, (int, float, np.integer, np.floating)):
        yield where, float(value)
    elif isinstance(value, np.ndarray):
        for i, v in enumerate(value.ravel()):
            yield f"{where}[{i}]", float(v)
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _numbers(v, f"{where}.{k}")
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from _numbers(v, f"{where}[{i}]")


def assert_finite(sc) -> None:
    """Every number a validated Scenario holds is finite (no NaN or inf slipped through):
    dt, duration, task parameters and targets, shapes, pushes, sensing, trajectories
    sampled over the run, offsets, events and the robot's default posture."""
    parts = {"dt": sc.dt, "duration": sc.duration, "pushes": sc.pushes, "sensing": sc.sensing,
             "offsets": sc.offsets, "solver": sc.solver, "q_default": sc.robot.q_default,
             "stack": [t.params() for t in sc.stack],
             "environment": [{k: v for k, v in vars(e).items()} for e in sc.environment],
             "events": [{k: (v.params() if k == "task" else v) for k, v in e.items() if k != "trajectory"}
                        for e in sc.events]}
    trajectories = [traj for traj, _ in sc.references.values()] + \
        [e["trajectory"][0] for e in sc.events if "trajectory" in e]
    times = np.linspace(0.0, sc.duration, 7).tolist() + [sc.dt, 2 * sc.dt]
    parts["samples"] = [traj.sample(t) for traj in trajectories for t in times]
    bad = [(w, x) for w, x in _numbers(parts, "scenario") if not math.isfinite(x)]
    assert not bad, f"non-finite values in a validated scenario: {bad[:5]}"


def outcome(path, loader, cycles: int = 0, stats: Counter | None = None) -> str:
    """Load ``path`` (and run ``cycles`` control cycles if it loads): "valid", "ran" or
    "error". Fails on any exception that is not a ConfigError naming the file and a key."""
    try:
        sc = load_config(path, robot_loader=loader)
    except WbcError as exc:
        msg = str(exc)
        assert isinstance(exc, ConfigError), f"{type(exc).__name__} instead of ConfigError: {msg}"
        assert msg.startswith(str(path)), f"does not name the file first: {msg}"
        assert exc.key and exc.key in msg, f"names no key path: {msg}"
        assert "Traceback" not in msg and len(msg) < 2000, msg
        if stats is not None:
            stats[f"error:{exc.key.split('.')[0].split('[')[0]}"] += 1
        return "error"
    assert_finite(sc)
    if not cycles:
        return "valid"
    metrics = run(sc, duration=cycles * sc.dt)
    # a run ends early only when the robot fell or a stop was reported (the simulation
    # diverged, e.g. a table moved into the robot; the controller stopped), with the reason
    stopped = metrics["stopped"]
    assert metrics["duration"] == pytest.approx(cycles * sc.dt) or metrics["fell"] or (stopped and stopped["reason"])
    return "ran"


@pytest.mark.parametrize("name", sorted(SYNTHETIC))
def test_the_synthetic_base_documents_are_valid_and_run_through_their_events(name, robot_cache, tmp_path):
    """The fuzz's extra base documents (every task type, parameter and section) start valid."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(SYNTHETIC[name])
    assert outcome(path, robot_cache, cycles=30) == "ran"


def _fuzz(documents, loader, tmp_path, n_cases: int, profile: str) -> Counter:
    stats: Counter = Counter()

    @settings(settings.get_profile(profile), max_examples=n_cases)
    @given(case=mutated(documents))
    def check(case):
        name, doc, done = case
        path = write_yaml(tmp_path / f"{name}.yaml", doc)
        result = outcome(path, loader, cycles=3, stats=stats)      # every valid one runs
        stats[result] += 1
        stats["cases"] += 1

    check()
    return stats


def _report(title: str, stats: Counter) -> None:
    kinds = {k: v for k, v in stats.items() if k.startswith("error:")}
    print(f"\n{title}: {stats['cases']} cases, {stats['ran']} valid set-ups (each run for 3 cycles), "
          f"{stats['error']} ConfigErrors, 0 other exceptions; "
          f"errors by section {dict(sorted(kinds.items(), key=lambda kv: -kv[1]))}")


def test_mutated_scenarios_load_and_run_or_name_file_and_key(scenario_documents, robot_cache, tmp_path):
    stats = _fuzz(scenario_documents, robot_cache, tmp_path, DEFAULT_CASES, "wbc-default")
    _report("scenario fuzz", stats)
    assert stats["cases"] >= DEFAULT_CASES * 0.95         # hypothesis ran (nearly) every case asked
    # both outcomes are well represented: the fuzz is neither all-junk nor all-benign (hypothesis draws
    # some values from constants in the loaded modules: the counts vary a little with the tests run before)
    assert stats["error"] > 0.3 * stats["cases"]
    assert stats["ran"] > 0.05 * stats["cases"]


@pytest.mark.slow
def test_mutated_scenarios_many_more_random_cases(scenario_documents, robot_cache, tmp_path):
    stats = _fuzz(scenario_documents, robot_cache, tmp_path, DEFAULT_CASES * SLOW_FACTOR, "wbc-slow")
    _report("scenario fuzz (slow)", stats)
    assert stats["cases"] >= DEFAULT_CASES * SLOW_FACTOR * 0.95


# ---------------------------------------------------------------- event timelines
_TASKS = {
    "left_foot_contact": {"type": "contact", "contact": "left_foot"},
    "right_foot_contact": {"type": "contact", "contact": "right_foot"},
    "right_swing": {"type": "frame", "frame": "right_foot", "name": "right_swing", "kp": 400.0},
    "hand": {"type": "frame", "frame": "right_hand", "name": "hand", "mask": "position"},
    "com2": {"type": "com", "name": "com2", "axes": "z"},
    "wrench": {"type": "contact_wrench", "contact": "left_foot_contact", "name": "wrench", "weight": 0.1},
}
_NAMES = [*_TASKS, "com", "posture", "torso", "joint_limits"]


@st.composite
def timelines(draw) -> dict:
    """talos_step's stack with 1-6 events inside a 25 ms run: mostly consistent with the
    names in the stack (a rough replay, which ignores force ramps), sometimes not."""
    dt, duration = 0.001, 0.025
    present = {"left_foot_contact", "right_foot_contact", "com", "torso", "posture", "joint_limits", "torque_limits"}
    stack = [[{"type": "joint_limits"}, {"type": "torque_limits"}, _TASKS["left_foot_contact"],
              _TASKS["right_foot_contact"]],
             [{"type": "com", "kp": 100.0}], [{"type": "frame", "frame": "torso", "mask": "orientation"}],
             [{"type": "posture", "kp": 10.0}]]
    if draw(st.booleans()):
        stack[2].append(_TASKS["wrench"])
        present.add("wrench")
    times = sorted(draw(st.lists(st.sampled_from([0.0, 0.001, 0.0015, 0.003, 0.004, 0.005, 0.01, 0.012, 0.02,
                                                  0.0249]), min_size=1, max_size=6)))
    events = []
    for time in times:
        kind = draw(st.sampled_from(["release", "remove", "add", "touchdown"]))
        consistent = draw(st.integers(0, 4)) > 0
        ev: dict = {"time": time}
        if kind in ("release", "remove"):
            pool = sorted(present & ({"left_foot_contact", "right_foot_contact"} if kind == "release" else present))
            name = draw(st.sampled_from(pool)) if consistent and pool else draw(st.sampled_from(_NAMES))
            ev[kind] = name
            present.discard(name)
        else:
            pool = ["left_foot_contact", "right_foot_contact"] if kind == "touchdown" else list(_TASKS)
            free = [n for n in pool if n not in present]
            name = draw(st.sampled_from(free)) if consistent and free else draw(st.sampled_from(pool))
            ev[kind] = dict(_TASKS[name])
            present.add(name)
            if kind == "touchdown" or draw(st.booleans()):
                ev["level"] = draw(st.integers(0, 5)) if not consistent else draw(st.integers(0, 2))
            if kind == "add" and ev["add"]["type"] in ("frame", "com") and draw(st.booleans()):
                ev["trajectory"] = {"type": "sinusoid", "amplitude": [0.0, 0.0, 0.01], "frequency": 2.0}
        if kind in ("release", "touchdown"):
            ev["duration"] = draw(st.sampled_from([0.001, 0.002, 0.004, 0.01, 0.2]))
        events.append(ev)
    return {"name": "timeline", "robot": "talos", "control": {"dt": dt}, "duration": duration,
            "stack": stack, "events": draw(st.permutations(events))}


def test_random_event_timelines_that_validate_run_to_the_end(robot_cache, tmp_path):
    """Every timeline that validates runs all its events (to the run's end) without an
    exception: the checks replay the events exactly as the runner and controller apply them."""
    stats: Counter = Counter()

    @settings(settings.get_profile("wbc-default"), max_examples=TIMELINE_CASES)
    @given(doc=timelines())
    def check(doc):
        path = write_yaml(tmp_path / "timeline.yaml", doc)
        stats[outcome(path, robot_cache, cycles=25)] += 1

    check()
    print(f"\nevent timelines: {sum(stats.values())} cases, {stats['ran']} valid and run for 25 cycles, "
          f"{stats['error']} ConfigErrors")
    assert stats["ran"] >= 20 and stats["error"] >= 20
