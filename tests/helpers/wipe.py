"""The wiping scenarios (tasks/tiago_wipe.yaml, tasks/talos_wipe.yaml) and their variants:
the force measured by the momentum observer instead of the simulator, no integral action,
a constant unmodelled force on the hand (a payload the controller does not know)."""

from __future__ import annotations

import numpy as np

from wbc.runner.loop import run
from wbc.scenario.loader import load_config
from wbc.tasks import Force


def wipe(name: str, *, source: str = "simulator", integral: bool = True, bias: float = 0.0, **run_kw) -> dict:
    """The metrics of scenario ``name`` run with its force task measuring from ``source``,
    with (the scenario's K_I) or without integral action, and ``bias`` N pressing the hand down
    from t = 0 (a push the controller does not know of)."""
    sc = load_config(name)
    force = next(t for t in sc.stack if isinstance(t, Force))
    force.source = source
    if not integral:
        force.ki = 0.0
    if bias:
        hand = sc.robot.model.frames[sc.robot.frame_id(sc.robot.contacts["hand_pad"].frame)].name
        sc.pushes.append({"frame": hand, "force": np.array([0.0, 0.0, -bias]), "start": 0.0,
                          "duration": 3600.0})
    return run(sc, **run_kw)


def figures(m: dict) -> dict:
    """The force task's figures (wbc.interaction.measurement)."""
    return next(iter(m["interaction"].values()))


def assert_accepted(m: dict, name: str, stroke: float, feet: bool = False) -> None:
    """The scenario's acceptance (its ``acceptance:`` figures) on a wipe run's metrics: no fall,
    failure, saturation or violation, no contact lost, the force and path errors within
    bounds, a stroke longer than ``stroke`` (m); ``feet``: the feet neither lift nor slip 1 mm."""
    accept = load_config(name).acceptance
    f = figures(m)
    assert not m["fell"] and m["solver_failures"] == 0 and m["saturated_cycles"] == 0
    assert sum(m["violations"].values()) == 0, m["violations"]
    assert f["contact_lost_cycles"] == 0
    assert m["normal_force_rms_error"] < accept["normal_force_rms_error"]
    assert m["path_error_max"] < accept["path_error_max"]
    assert f["slide_length"] > stroke
    if feet:
        assert all(not c["lifted"] and c["slip"] < 1e-3 for c in m["contacts"].values())
