"""``solver.damping`` in a scenario YAML (wbc.scenario.sections.damping_value): the run's solver
takes the threshold ε and the bound λ_max given; a bad value is exit 2 naming file, line and
key path."""

from __future__ import annotations

import pytest

from wbc.cli.main import main
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config


def _with_solver(tmp_path, solver_line: str):
    lines = load_config("panda_reach_boundary").source.read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("solver:"))
    lines[i] = solver_line
    path = tmp_path / "damped.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path, i + 1


@pytest.mark.parametrize("solver", ["hqp", "projection", "weighted"])
def test_the_damping_given_is_the_solvers(tmp_path, solver):
    path, _ = _with_solver(tmp_path, f"solver: {{type: {solver}, damping: {{threshold: 0.05, max_damping: 0.04}}}}")
    d = ScenarioRun(load_config(path), progress=False, duration=0.002).ctrl.solver.damping
    assert (d.threshold, d.max_damping) == (0.05, 0.04)
    path, _ = _with_solver(tmp_path, f"solver: {{type: {solver}, damping: {{threshold: 0.03}}}}")
    d = ScenarioRun(load_config(path), progress=False, duration=0.002).ctrl.solver.damping
    assert (d.threshold, d.max_damping) == (0.03, 0.01)         # the bound left at its default


@pytest.mark.parametrize("value,key,says", [
    ("{threshold: -0.01}", "solver.damping.threshold", "in [0, 1]"),
    ("{max_damping: 2}", "solver.damping.max_damping", "in [0, 1]"),
    ("{treshold: 0.01}", "solver.damping", "threshold"),
    ("0.01", "solver.damping", "mapping"),
])
def test_bad_damping_is_exit_2_with_file_line_and_key(tmp_path, capsys, value, key, says):
    path, line = _with_solver(tmp_path, f"solver: {{type: hqp, damping: {value}}}")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"damped.yaml:{line}" in err and key in err and says in err, err
