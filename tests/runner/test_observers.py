"""The run's observers: one protocol (wbc.runner.observers), called in list order at each point
of the cycle, with the cycle's one record; and one options record (RunOptions) from the CLI
down (its fields as keywords too; an unknown one is a TypeError)."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.runner.loop import ScenarioRun, run
from wbc.runner.observers import MetricsObserver, RunObserver
from wbc.runner.options import RunOptions
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config


class Log(RunObserver):
    """Keeps the hooks called, and what it saw at each."""

    def __init__(self):
        self.calls, self.seen = [], []

    def after_events(self, c):
        self.calls.append(("after_events", c.k))

    def before_solve(self, c):
        assert c.sol is None
        self.calls.append(("before_solve", c.k))

    def after_solve(self, c):
        self.calls.append(("after_solve", c.k))
        self.seen.append((c.q.copy(), c.sol.tau_full.copy()))

    def after_step(self, c):
        assert np.array_equal(c.sim.q, c.sim.q)  # the simulator's state is there
        self.calls.append(("after_step", c.k))

    def summary(self):
        return {"log_cycles": sum(1 for name, _ in self.calls if name == "after_step")}


def test_hooks_run_in_cycle_order_and_add_to_the_metrics():
    log = Log()
    sc = load_config(SCENARIOS_DIR / "talos_balance.yaml")
    m = run(sc, RunOptions(duration=0.005, observers=[log]))
    assert m["log_cycles"] == 5
    want = [("after_events", 0)]
    for k in range(5):
        want += [("before_solve", k), ("after_solve", k), ("after_step", k)]
    assert log.calls == want


def test_the_metrics_come_last_and_user_observers_see_the_command():
    log = Log()
    sc = load_config(SCENARIOS_DIR / "talos_balance.yaml")
    r = ScenarioRun(sc, duration=0.003, observers=[log])
    assert isinstance(r.observers[-1], MetricsObserver) and log in r.observers
    sols = []
    solve = r.ctrl.solve
    r.ctrl.solve = lambda q, v, tau_e=None: sols.append(solve(q, v, tau_e)) or sols[-1]
    for k in range(r.n):
        assert r.cycle(k)
    for (_q, tau), sol in zip(log.seen, sols):
        np.testing.assert_array_equal(tau, sol.tau_full)


def test_options_and_keywords_are_one_record():
    sc = load_config(SCENARIOS_DIR / "talos_balance.yaml")
    a = ScenarioRun(sc, RunOptions(duration=0.004, solver="projection"))
    b = ScenarioRun(sc, duration=0.004, solver="projection")
    c = ScenarioRun(sc, RunOptions(duration=0.5), duration=0.004, solver="projection")   # keywords over options
    assert a.options == b.options == c.options and (a.n, a.solver_name) == (4, "projection")
    with pytest.raises(TypeError, match="unknown run setting.*'solvr'"):
        ScenarioRun(sc, solvr="hqp")
