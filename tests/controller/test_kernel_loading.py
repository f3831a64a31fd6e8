"""A torque cycle's first back-end QP loads no kernel (:mod:`wbc.controller.kernel_loading`): the
plain cascade run it switches to was loaded with the first cycle's kernels, not in the middle of
the run (70-80 ms of CPU against a 1 ms period: ``talos_push``'s push, #26). Nor does the torque
plan's first run (:func:`wbc.tasks.torque_stack.load_rows_kernel`: loaded with the first cycle's
kernels, 12-22 ms that were spent in the run's third cycle).

Numba's loaded kernels are per process and other tests load them, so the run is made in a fresh
interpreter: the bench's Talos stack over 7 levels, whose cycle 14 is its first with a QP."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import json, sys, warnings
from numba.core.registry import CPUDispatcher
from benchmarks.harness import stacks, timing
from wbc.robot.loader import load_robot

warnings.simplefilter("ignore")

def loaded():
    out = {}
    for m in list(sys.modules.values()):
        if getattr(m, "__name__", "").startswith("wbc"):
            for v in list(vars(m).values()):
                if isinstance(v, CPUDispatcher):
                    out[v.py_func.__module__ + "." + v.py_func.__name__] = len(v.overloads)
    return out

if sys.argv[1:] == ["plan"]:       # the bench's stack: planned in cycle 1, first run by the plan in cycle 2
    run = timing.CycleRun(load_robot("talos"), stacks.talos_stack, "hqp", "daqp", ("right_hand", "left_hand"))
    new = {}
    for k in range(6):
        before = loaded()
        run.step(k)
        after = loaded()
        new[k] = sorted(n for n in after if after[n] != before.get(n, 0))
    print(json.dumps({"plan": run.stack._plan[1] is not None, "new": new}))
    sys.exit(0)
run = timing.CycleRun(load_robot("talos"), lambda: stacks.talos_levels_stack(7), "hqp", "daqp",
                      ("right_hand", "left_hand"))
first = None
for k in range(30):
    before = loaded()
    sol = run.step(k)[1]
    if k > 0 and sol.qp_count > 0:
        after = loaded()
        first = {"cycle": k, "new": sorted(n for n in after if after[n] != before.get(n, 0))}
        break
print(json.dumps(first))
"""


def test_the_first_qp_cycle_loads_no_kernel():
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=600, check=True)
    first = json.loads(out.stdout.strip().splitlines()[-1])
    assert first is not None, "no cycle needed a back-end QP: the case no longer tests the switch"
    assert first["new"] == [], f"cycle {first['cycle']}, the first with a QP, loaded kernels {first['new']}"


def test_the_torque_plans_first_run_loads_no_kernel():
    """The bench's stack: its torque plan is made in cycle 1 (after the tasks filled the buffer in
    cycle 0) and writes the rows from cycle 2 on; its kernel is loaded in cycle 0, with the others,
    and no later cycle loads one."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT, "plan"], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=600, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["plan"], "the stack has no torque plan: the case no longer tests its loading"
    assert "wbc.tasks.torque_stack._torque_rows" in got["new"]["0"], got["new"]
    later = {k: v for k, v in got["new"].items() if int(k) > 0 and v}
    assert not later, f"kernels loaded after the first cycle: {later}"
