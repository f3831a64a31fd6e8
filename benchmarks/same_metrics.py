"""Same metrics before and after a change: every value of a run's metrics JSON compared.

    python benchmarks/same_metrics.py record OUT.json [SCENARIO,...] [pinocchio,mujoco] [ULP_SEED [ULPS]]
    python benchmarks/same_metrics.py compare BEFORE.json AFTER.json

``record`` runs, on the tree it is run from (PYTHONPATH), each scenario (default
talos_balance, talos_walk, tiago_table_reach, talos_glass; their whole duration) in each
simulator with the scenario's own solver, with ``series=True``, and stores its metrics dict
(what ``wbc run --metrics`` writes). ``compare`` walks both files key by key, the wall-clock
figures left out (:data:`WALL_CLOCK`: ``cycle_time``, ``real_time_factor``, the walker's
``replan_time``), and prints every value that is not exactly equal (floats compared bit for
bit, as JSON writes them: repr round-trips), then ``N/N identical``; exit 1 when any differs.

With ULP_SEED (an integer), ``record`` runs the tree's controller with its rounding disturbed: every
cycle, each non-zero component of the torque sent to the simulator is moved by one unit in the last
place, up or down at random (seeded); with ULPS, by that many units (relative ULPS·2⁻⁵², the size of
what ``same_replay.py compare`` reports for a change, so that the yardstick is as large as the
change's own per-cycle difference). Two such recordings, or one against an undisturbed one, show how
far a scenario's metrics move under rounding alone: the yardstick for a change that moves the last bits
of the controller's answers (``same_replay.py`` checks that change per cycle, open loop).
"""

from __future__ import annotations

import json
import math
import sys
import warnings

SCENARIOS = ("talos_balance", "talos_walk", "tiago_table_reach", "talos_glass")
#: wall-clock figures (they differ between any two runs), left out at any depth
WALL_CLOCK = ("cycle_time", "real_time_factor", "replan_time")


def record(path: str, scenarios: list[str], simulators: list[str], ulp_seed: int | None = None,
           ulps: int = 1) -> None:
    from wbc.controller.cycle import Controller
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    warnings.simplefilter("ignore")
    solve = Controller.solve
    if ulp_seed is not None:
        import numpy as np

        rng = np.random.default_rng(ulp_seed)

        def disturbed(self, *args, **kwargs):
            sol = solve(self, *args, **kwargs)
            tau = getattr(sol, "tau_full", None)
            if tau is not None:
                up = rng.random(tau.shape[0]) < 0.5
                if ulps == 1:
                    moved = np.where(up, np.nextafter(tau, np.inf), np.nextafter(tau, -np.inf))
                else:
                    moved = tau * (1.0 + np.where(up, ulps, -ulps) * np.finfo(float).eps)
                tau[:] = np.where(tau != 0.0, moved, tau)
            return sol

        Controller.solve = disturbed                    # type: ignore[method-assign]
    out = {}
    try:
        for name in scenarios:
            for sim in simulators:
                out[f"{name}/{sim}"] = run(load_config(name), simulator=sim, series=True)
                print(f"{name}/{sim} recorded", flush=True)
    finally:
        Controller.solve = solve                        # type: ignore[method-assign]
    with open(path, "w") as f:
        json.dump(out, f, allow_nan=True)


def differences(a, b, path: str = "") -> list[str]:
    """Every place where ``a`` and ``b`` differ (a key path and both values)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{path}/{k}: only {'before' if k in a else 'after'}" for k in sorted(set(a) ^ set(b))
               if k not in WALL_CLOCK]
        for k in a:
            if k in b and k not in WALL_CLOCK:
                out += differences(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} and {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{path}[{i}]")]
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return []
    if type(a) is not type(b) or a != b:
        return [f"{path}: {a!r} and {b!r}"]
    return []


def compare(before: str, after: str) -> int:
    with open(before) as f:
        a = json.load(f)
    with open(after) as f:
        b = json.load(f)
    same = 0
    for key in a:
        d = differences(a[key], b.get(key, {}))
        if d:
            print(f"{key}: {len(d)} values differ")
            for line in d[:20]:
                print("   ", line)
        else:
            print(f"{key}: identical")
            same += 1
    print(f"{same}/{len(a)} identical")
    return 0 if same == len(a) and set(a) == set(b) else 1


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "record":
        record(sys.argv[2], sys.argv[3].split(",") if len(sys.argv) > 3 else list(SCENARIOS),
               sys.argv[4].split(",") if len(sys.argv) > 4 else ["pinocchio", "mujoco"],
               int(sys.argv[5]) if len(sys.argv) > 5 else None, int(sys.argv[6]) if len(sys.argv) > 6 else 1)
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        sys.exit(__doc__)
