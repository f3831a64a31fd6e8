"""Sweep, one value at a time: every leaf of every bundled scenario and robot YAML (and of the
synthetic scenarios that use every task parameter) replaced by each value of a fixed set
(NaN, ±inf, ±1.7e308, huge ints, numeric text, booleans, null, lists, mappings, unicode,
...), and every key deleted or misspelt. Each case validates, in which case every number
in the Scenario is finite and the scenario runs 3 control cycles, or is refused with an
error naming the file and the key path. The default suite takes a deterministic stride of
the cases (a few thousand); ``-m slow`` takes all of them. Every valid scenario is run; of
the robots, those of the third test (and every one under ``-m slow``)."""

from __future__ import annotations

import copy
import math
from collections import Counter

import pytest

from .conftest import write_yaml
from .mutations import SPECIAL_NUMBERS, get, paths
from .test_fuzz_robots import robot_outcome
from .test_fuzz_scenarios import outcome

#: what any leaf (not only a number) is replaced by
ANY_LEAF = [None, "", "ё🤖", 0, -1, 1.5, True, [], [1.0, 2.0, 3.0], {}, {"x": 1}, [[1.0]], "left_foot"]


def _cases(documents):
    for name, doc in documents:
        for path in paths(doc):
            value = get(doc, path)
            leaf = not isinstance(value, (dict, list))
            numeric = leaf and isinstance(value, (int, float)) and not isinstance(value, bool)
            replacements = (SPECIAL_NUMBERS if numeric else []) + (ANY_LEAF if leaf else [None, 7, "x"])
            for new in replacements:
                if new == value and type(new) is type(value):
                    continue
                mutated = copy.deepcopy(doc)
                get(mutated, path[:-1])[path[-1]] = copy.deepcopy(new)
                yield name, mutated, f"{path}={new!r}"
            if isinstance(path[-1], str):       # the key deleted, then misspelt
                for key in (None, path[-1] + "x"):
                    mutated = copy.deepcopy(doc)
                    parent = get(mutated, path[:-1])
                    moved = parent.pop(path[-1])
                    if key is not None:
                        parent[key] = moved
                    yield name, mutated, f"{path} {'deleted' if key is None else f'renamed {key}'}"


def _strided(cases: list, target: int | None) -> list:
    """Every k-th case, k chosen to keep about ``target`` of them (all if None): each leaf
    still gets several of its replacement values, whatever the number of bundled files."""
    if target is None or len(cases) <= target:
        return cases
    return cases[:: math.ceil(len(cases) / target)]


def _scenario_sweep(documents, loader, tmp_path, run_every: int, target: int | None) -> Counter:
    stats: Counter = Counter()
    for k, (name, doc, what) in enumerate(_strided(list(_cases(documents)), target)):
        path = write_yaml(tmp_path / f"{name}.yaml", doc)
        try:
            stats[outcome(path, loader, cycles=3 if k % run_every == 0 else 0)] += 1
        except Exception as exc:        # name the case whatever went wrong
            raise AssertionError(f"{name}: {what}: {type(exc).__name__}: {exc}") from exc
    total = sum(stats.values())
    print(f"\nscenario sweep: {total} cases, {stats['ran'] + stats['valid']} valid ({stats['ran']} run for 3 cycles), "
          f"{stats['error']} ConfigErrors, 0 other exceptions")
    return stats


def _robot_sweep(documents, tmp_path, cycles: int, target: int | None) -> Counter:
    stats: Counter = Counter()
    docs = dict(documents)
    for name, doc, what in _strided(list(_cases(documents)), target):
        path = write_yaml(tmp_path / "robot.yaml", doc)
        try:
            stats[robot_outcome(path, name, cycles, stats, docs[name])] += 1
        except Exception as exc:        # name the case whatever went wrong
            raise AssertionError(f"{name}: {what}: {type(exc).__name__}: {exc}") from exc
    loaded = stats["valid"] + stats["ran"] + stats["valid, scenario refused"]
    print(f"\nrobot sweep: {loaded + stats['error']} cases, {loaded} loaded ({stats['ran']} run in a scenario for "
          f"{cycles} cycles), {stats['error']} RobotDefinitionErrors, 0 other exceptions")
    return stats


def test_scenario_leaves_replaced_one_at_a_time(scenario_documents, robot_cache, tmp_path):
    # a stride of ~1,000 over the leaves (the full sweep is the slow test below); halved from 2,000
    # as the bundled scenarios grew, to keep the default suite inside its 15 minutes
    stats = _scenario_sweep(scenario_documents, robot_cache, tmp_path, 1, target=1000)
    assert sum(stats.values()) >= 800 and stats["ran"] > 75 and stats["valid"] == 0 and stats["error"] > 600


def test_robot_leaves_replaced_one_at_a_time(robot_documents, tmp_path):
    stats = _robot_sweep(robot_documents, tmp_path, 0, target=900)
    assert stats["valid"] + stats["error"] >= 700 and stats["valid"] > 80 and stats["error"] > 500


def test_robot_leaves_replaced_one_at_a_time_then_run_in_a_scenario(robot_documents, tmp_path):
    stats = _robot_sweep(robot_documents, tmp_path, 3, target=250)
    # a floor on coverage (the failures raise above): the stride over the bundled robots' leaves runs
    # 30-31 of the 250 cases since g1_straight joined them
    assert stats["ran"] >= 28


@pytest.mark.slow
def test_every_scenario_leaf_replaced_one_at_a_time(scenario_documents, robot_cache, tmp_path):
    stats = _scenario_sweep(scenario_documents, robot_cache, tmp_path, 1, target=None)
    assert stats["ran"] > 500 and stats["valid"] == 0


@pytest.mark.slow
def test_every_robot_leaf_and_every_valid_robot_runs(robot_documents, tmp_path):
    stats = _robot_sweep(robot_documents, tmp_path, 3, target=None)
    assert stats["ran"] > 200 and stats["valid"] == 0
