"""A/B in one process (issue #26): the own simulator's step with contact_solver "compiled" and
"pinocchio" (and, given OLD, a copy of another tree's simulator: a directory holding
wbc_old/{__init__,errors}.py and wbc_old/sim/{__init__,simulator,contact_solver,joint_dynamics}.py),
interleaved step by step on the states of one talos_balance closed loop (thread CPU time).

    PYTHONPATH=. python benchmarks/sim_step_ab.py [SECONDS] [OLD]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import pinocchio as pin

from wbc.runner.loop import run
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config
from wbc.sim.simulator import Simulator


def main(seconds: float = 2.0, old: str | None = None) -> None:
    warnings.simplefilter("ignore")
    states, holder = [], {}

    def keep(s):
        holder["sim"] = s
        return s

    run(load_config(SCENARIOS_DIR / "talos_balance.yaml"), solver="hqp", duration=seconds, wrap_simulator=keep,
        callback=lambda t, sim, sol: states.append((sim.q.copy(), sim.v.copy(), sol.tau_full.copy())))
    base = holder["sim"]
    args = (base.model, [(base.model.names[j], r) for j, r in base.points], base.env, states[0][0])
    kw = {"dt": base.dt, "actuated": base.actuated, "tau_limits": base.tau_limits}
    sims = {name: Simulator(*args, contact_solver=name, **kw) for name in ("compiled", "pinocchio")}
    if old:
        sys.path.insert(0, old)
        from wbc_old.sim.simulator import Simulator as OldSimulator
        sims["old"] = OldSimulator(*args, **kw)
    times: dict[str, list[float]] = {k: [] for k in sims}
    for q, v, tau in states:
        for k, s in sims.items():
            s.q, s.v = q.copy(), v.copy()
            t0 = time.thread_time_ns()
            s.step(tau)
            times[k].append((time.thread_time_ns() - t0) / 1e3)
    med = {k: float(np.median(x[100:])) for k, x in times.items()}
    for k, x in times.items():
        print(f"pinocchio {pin.__version__} {k:10s} step median {med[k]:6.1f} µs, p90 {np.percentile(x[100:], 90):6.1f}")
    print("ratios to compiled: " + ", ".join(f"{k} {med[k] / med['compiled']:.2f}" for k in med))


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 2.0, sys.argv[2] if len(sys.argv) > 2 else None)
