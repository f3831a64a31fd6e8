"""The own simulator's closed loop with each contact solver in one process (issue #26): max |Δq|
over the run, the compiled PGS against pinocchio's binding, per scenario and solver.

    PYTHONPATH=. python benchmarks/contact_solver_agreement.py talos_balance,talos_push
"""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pinocchio as pin

import wbc.sim.simulator as simulator
from wbc.runner.loop import run
from wbc.scenario.loader import load_config


def main(scenarios: list[str]) -> None:
    warnings.simplefilter("ignore")
    original = simulator.Simulator.__init__
    for scenario in scenarios:
        for solver in ("hqp", "projection", "weighted"):
            qs = {}
            for name in ("compiled", "pinocchio"):
                def init(self, *a, _name=name, **k):
                    k.setdefault("contact_solver", _name)
                    original(self, *a, **k)

                simulator.Simulator.__init__ = init
                traj: list = []
                try:
                    run(load_config(scenario), solver=solver, simulator="pinocchio",
                        duration=1.6 if scenario == "talos_push" else 1.0,
                        callback=lambda t, s, sol, traj=traj: traj.append(s.q.copy()))
                finally:
                    simulator.Simulator.__init__ = original
                qs[name] = np.array(traj)
            a, b = qs["compiled"], qs["pinocchio"]
            what = f"lengths {len(a)} and {len(b)}" if a.shape != b.shape else f"max |Δq| {np.abs(a - b).max():.2g}"
            print(f"pinocchio {pin.__version__} {scenario}/{solver}: {what}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1].split(",") if len(sys.argv) > 1 else ["talos_balance"])
