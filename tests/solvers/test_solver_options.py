"""An option the chosen solver does not take is a ConfigError naming the option and the solver
(it used to be dropped silently: ``weighting`` given to ``hqp`` did nothing); the options a
solver does take reach it."""

from __future__ import annotations

import pytest

import wbc
from wbc.errors import ConfigError
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config
from wbc.solvers import SOLVER_OPTIONS, create_solver


@pytest.fixture(scope="module")
def talos():
    return wbc.load_robot("talos")


def stack():
    return wbc.Stack([[wbc.tasks.CoM()]])


@pytest.mark.parametrize("solver, option, value", [("hqp", "weighting", "inertia"), ("hqp", "level_weight", 0.1),
                                                   ("projection", "level_weight", 0.1),
                                                   ("weighted", "weighting", "inertia")])
def test_an_option_the_solver_does_not_take_is_an_error(talos, solver, option, value):
    with pytest.raises(ConfigError) as err:
        wbc.Controller(talos, stack(), solver=solver, **{option: value})
    msg = str(err.value)
    assert f"'{solver}'" in msg and f"'{option}'" in msg
    owner = "projection" if option == "weighting" else "weighted"
    assert f"the {owner} solver" in msg


def test_an_unknown_option_names_no_owner():
    with pytest.raises(ConfigError, match="'tolerance'.*not an option of any solver"):
        create_solver("hqp", tolerance=1e-3)


def test_the_options_a_solver_takes_reach_it(talos):
    assert wbc.Controller(talos, stack(), solver="projection", weighting="inertia").solver.weighting == "inertia"
    assert wbc.Controller(talos, stack(), solver="weighted", level_weight=0.1).solver.level_weight == 0.1
    assert wbc.Controller(talos, stack(), solver="projection").solver.weighting == "identity"
    assert set(SOLVER_OPTIONS) == {"hqp", "projection", "weighted"}


SCENARIO = """robot: talos
solver: {type: hqp, weighting: inertia}
stack:
  - - {type: contact, contact: left_foot}
    - {type: contact, contact: right_foot}
  - - {type: com}
"""


def test_a_scenario_names_file_line_and_key(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert (err.value.key, err.value.line) == ("solver.weighting", 2) and str(path) in str(err.value)


def test_a_solver_chosen_over_the_scenarios_must_take_its_options(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(SCENARIO.replace("type: hqp", "type: projection"))
    sc = load_config(path)
    ScenarioRun(sc, duration=0.002)                     # the scenario's own solver takes it
    with pytest.raises(ConfigError, match="scenario's solver is 'projection'; this run's is 'hqp'") as err:
        ScenarioRun(sc, solver="hqp", duration=0.002)
    assert err.value.key == "solver.weighting" and str(path) in str(err.value)
