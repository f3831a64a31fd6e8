"""Fuzz: mutated robot YAMLs either load into a RobotModel that a scenario can run, or are
refused with a RobotDefinitionError naming the file and the key path; nothing else.

The cases are the bundled robots (talos, tiago, panda) with 1-3 mutations each (see
``mutations.py``). For every robot that loads, a scenario on that robot file
(the bundled one for talos and tiago, a small arm stack for panda) is loaded and run for a
few control cycles: it runs, or is refused with a ConfigError naming its file and a key.
"""

from __future__ import annotations

from collections import Counter

import pytest
from hypothesis import given, settings

import wbc
from wbc.errors import RobotDefinitionError, RobotNotFound, WbcError

from .conftest import SLOW_FACTOR, write_yaml
from .mutations import mutated
from .test_fuzz_scenarios import outcome

DEFAULT_CASES = 650

_SCENARIOS = {
    "talos": {"duration": 1.0, "stack": [
        [{"type": "joint_limits"}, {"type": "torque_limits"}, {"type": "contact", "contact": "left_foot"},
         {"type": "contact", "contact": "right_foot"}],
        [{"type": "com", "kp": 100.0}], [{"type": "frame", "frame": "torso", "mask": "orientation"}],
        [{"type": "posture", "kp": 10.0}]]},
    "tiago": {"duration": 1.0, "environment": [], "stack": [
        [{"type": "joint_limits"}, {"type": "torque_limits"}],
        [{"type": "frame", "frame": "hand", "kp": 4.0, "mask": "position", "offset": [0.1, 0.0, 0.0]}],
        [{"type": "posture", "kp": 5.0}]]},
    "panda": {"duration": 1.0, "environment": [], "stack": [
        [{"type": "joint_limits"}, {"type": "torque_limits"}],
        [{"type": "frame", "frame": "hand", "kp": 50.0}], [{"type": "posture", "kp": 10.0}]]},
}


def scenario_on(base: str, robot_doc: dict | None = None) -> dict:
    """A scenario for robot ``base``: the ones above, else contacts (if any) + CoM + posture."""
    if base in _SCENARIOS:
        return _SCENARIOS[base]
    contacts = list((robot_doc or {}).get("contacts") or {})
    stack = [[{"type": "joint_limits"}, {"type": "torque_limits"}] + [{"type": "contact", "contact": c}
                                                                      for c in contacts]]
    stack += [[{"type": "com", "kp": 100.0}]] if contacts else []
    return {"duration": 1.0, "stack": stack + [[{"type": "posture", "kp": 10.0}]],
            **({} if contacts else {"environment": []})}


def robot_outcome(path, base: str, cycles: int, stats: Counter, robot_doc: dict | None = None) -> str:
    try:
        wbc.load_robot(path)
    except WbcError as exc:
        msg = str(exc)
        assert isinstance(exc, (RobotDefinitionError, RobotNotFound)), f"{type(exc).__name__}: {msg}"
        assert msg.startswith(str(path)), f"does not name the file first: {msg}"
        assert exc.key and exc.key in msg, f"names no key path: {msg}"
        assert "Traceback" not in msg and len(msg) < 3000, msg
        stats[f"error:{exc.key.split('.')[0].split('[')[0]}"] += 1
        return "error"
    if not cycles:
        return "valid"
    scenario = write_yaml(path.parent / "on_robot.yaml", {"robot": path.name, **scenario_on(base, robot_doc)})
    return "ran" if outcome(scenario, wbc.load_robot, cycles=cycles) == "ran" else "valid, scenario refused"


def _fuzz(documents, tmp_path, n_cases: int, profile: str) -> Counter:
    stats: Counter = Counter()
    base_docs = dict(documents)

    @settings(settings.get_profile(profile), max_examples=n_cases)
    @given(case=mutated(documents))
    def check(case):
        name, doc, done = case
        path = write_yaml(tmp_path / "robot.yaml", doc)
        stats[robot_outcome(path, name, 3, stats, base_docs[name])] += 1      # every robot that loads runs
        stats["cases"] += 1

    check()
    return stats


def _report(title: str, stats: Counter) -> None:
    kinds = {k: v for k, v in stats.items() if k.startswith("error:")}
    valid = stats["valid"] + stats["ran"] + stats["valid, scenario refused"]
    print(f"\n{title}: {stats['cases']} cases, {valid} robots loaded ({stats['ran']} run in a scenario for 3 "
          f"cycles, {stats['valid, scenario refused']} refused by that scenario with a ConfigError), "
          f"{stats['error']} RobotDefinitionErrors, 0 other exceptions; "
          f"errors by key {dict(sorted(kinds.items(), key=lambda kv: -kv[1]))}")


def test_mutated_robot_yamls_load_and_run_or_name_file_and_key(robot_documents, tmp_path):
    stats = _fuzz(robot_documents, tmp_path, DEFAULT_CASES, "wbc-default")
    _report("robot fuzz", stats)
    assert stats["cases"] >= DEFAULT_CASES * 0.95
    assert stats["error"] > 0.3 * stats["cases"]
    assert stats["ran"] > 0.05 * stats["cases"] and stats["valid"] == 0


@pytest.mark.slow
def test_mutated_robot_yamls_many_more_random_cases(robot_documents, tmp_path):
    stats = _fuzz(robot_documents, tmp_path, DEFAULT_CASES * SLOW_FACTOR, "wbc-slow")
    _report("robot fuzz (slow)", stats)
    assert stats["cases"] >= DEFAULT_CASES * SLOW_FACTOR * 0.95
