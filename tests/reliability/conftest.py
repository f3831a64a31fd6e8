"""Fixtures of the reliability tests: a robot cache for the fuzz (loading a robot is the
slow part of loading a scenario), the bundled documents, and the fuzz's case counts."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, settings

import wbc
from wbc.robot.loader import ROBOTS_DIR
from wbc.scenario.examples import SCENARIOS_DIR

# The default suite is deterministic (same cases every run, nothing written to disk, no time
# limits); `-m slow` runs ten times as many, with fresh random cases.
_COMMON = dict(deadline=None, database=None, print_blob=True,
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                      HealthCheck.filter_too_much, HealthCheck.large_base_example])
settings.register_profile("wbc-default", derandomize=True, **_COMMON)
settings.register_profile("wbc-slow", derandomize=False, **_COMMON)

#: cases per fuzz test in the default suite; the slow variants run SLOW_FACTOR times more
SLOW_FACTOR = int(os.environ.get("WBC_FUZZ_SLOW_FACTOR", "10"))


@pytest.fixture(scope="session")
def robot_cache():
    """A ``robot_loader`` for :func:`wbc.load_config` that loads each robot once per session
    (errors are not cached: they are cheap and each case must see its own)."""
    cache: dict[str, wbc.RobotModel] = {}

    def load(target):
        key = str(target)
        if key not in cache:
            cache[key] = wbc.load_robot(target)
        return cache[key]

    return load


#: scenarios that use every task type, every task parameter and every scenario key (the bundled
#: ones leave some out), so that the fuzz and the sweep reach every check
SYNTHETIC = {
    "all_keys": """
name: all_keys
description: every task type and parameter, every section
robot: talos
solver: {type: weighted, backend: daqp, level_weight: 0.001}
control: {dt: 0.001, substeps: 1}
duration: 2.0
simulator: pinocchio
acceptance: {com_rms: 0.005}
environment:
  - {type: ground, mu: 0.8, height: 0.0}
  - {type: box, center: [2.0, 0.0, 0.4], size: [0.5, 0.5, 0.8], mu: 0.5, name: table}
stack:
  - - {type: joint_limits, dt: 0.001, horizon: 0.1, max_acceleration: 30.0, margin: 0.0, name: limits, weight: 1.0}
    - {type: torque_limits, scale: 1.0, name: torques, weight: 1.0}
    - {type: contact, contact: left_foot, kp: 10.0, kd: 6.0, weight: 1.0, name: lf, mu: 0.7, fmin: 0.0,
       bilateral: false, cop_margin: 0.2}
    - {type: contact, contact: right_foot, name: rf}
  - - {type: com, kp: [100.0, 100.0], kd: [20.0, 20.0], weight: 1.0, name: com, axes: xy,
       trajectory: {type: sinusoid, amplitude: [0.0, 0.01, 0.0], frequency: 0.5, phase: 0.0, ramp: 0.5,
                    absolute: false}}
  - - {type: frame, frame: right_hand, kp: 40.0, kd: 12.0, weight: 1.0, name: rh, mask: position,
       trajectory: {type: waypoints, times: [0.0, 1.0], points: [[0, 0, 0], [0.02, 0.0, 0.02]]}}
    - {type: frame, frame: left_hand, mask: [1, 1, 1, 0, 0, 0], offset: [0.0, 0.0, 0.01]}
    - {type: frame, frame: torso, mask: orientation, target: {position: [0.0, 0.0, 1.0],
       rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}}
    - {type: contact_wrench, contact: lf, target: [0.0, 0.0, 400.0, 0.0, 0.0, 0.0], weight: 0.001, name: lfw}
  - - {type: posture, kp: 10.0, kd: 6.0, weight: 1.0, name: posture}
    - {type: posture, kp: [5.0, 5.0], name: head, joints: [head_1_joint, head_2_joint]}
    - {type: contact_regularization, weight: 1.0, normal_weight: 0.1, name: reg}
pushes:
  - {frame: torso, force: [20.0, 0.0, 0.0], start: 0.5, duration: 0.1}
sensing: {noise_q: 0.0, noise_v: 0.0, latency_steps: 0}
events:
  - {time: 0.002, add: {type: com, name: com_z, axes: z, kp: 50.0}, level: 3,
     trajectory: {type: constant, value: [0.0, 0.0, -0.001], absolute: false}}
  - {time: 0.004, remove: com_z}
  - {time: 0.01, release: rf, duration: 0.005}
  - {time: 0.02, touchdown: {type: contact, contact: right_foot, name: rf2}, level: 0, duration: 0.005}
""",
    "panda_arm": """
name: panda_arm
robot: panda
solver: {type: projection, weighting: identity}
environment: []
duration: 1.0
stack:
  - - {type: joint_limits}
    - {type: torque_limits, scale: 0.9}
  - - {type: frame, frame: hand, kp: 100.0, target: [[1, 0, 0, 0.3], [0, -1, 0, 0.0], [0, 0, -1, 0.5], [0, 0, 0, 1]]}
  - - {type: null_space_impedance, frame: hand, k_q: [20, 20, 20, 20, 20, 20, 20], B_nu: 3.0, weight: 1.0,
       name: nsi}
  - - {type: posture, kp: 1.0, target: [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]}
""",
}


@pytest.fixture(scope="session")
def scenario_documents() -> list[tuple[str, dict]]:
    """The bundled scenarios and :data:`SYNTHETIC`, as plain data."""
    return [(p.stem, yaml.safe_load(p.read_text())) for p in sorted(SCENARIOS_DIR.glob("*.yaml"))] + \
        [(name, yaml.safe_load(text)) for name, text in SYNTHETIC.items()]


@pytest.fixture(scope="session")
def robot_documents() -> list[tuple[str, dict]]:
    return [(p.stem, yaml.safe_load(p.read_text())) for p in sorted(ROBOTS_DIR.glob("*.yaml"))
            if not p.name.endswith(".collisions.yaml")]          # a robot's collision pairs, not a robot


#: libyaml's emitter when PyYAML has it (the pure-Python one is most of a case's time)
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def write_yaml(path: Path, doc) -> Path:
    """``doc`` written as YAML (``yaml.safe_dump`` semantics) to ``path``."""
    path.write_text(yaml.dump(doc, Dumper=_DUMPER, sort_keys=False, allow_unicode=True))
    return path


@pytest.fixture(scope="session")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def panda_scenario(tmp_path: Path, **changes) -> wbc.Scenario:
    """:data:`SYNTHETIC`'s panda_arm scenario (joint and torque limits, a hand target, null-space
    impedance, posture) with top-level keys replaced by ``changes``."""
    doc = yaml.safe_load(SYNTHETIC["panda_arm"])
    doc.update(changes)
    return wbc.load_config(write_yaml(tmp_path / "panda_arm.yaml", doc))
