"""One whole bench (:func:`run`) and the ``wbc bench`` command's body (:func:`bench`).

The command's options are parsed by the package (:func:`wbc.cli.bench.add_parser`, so that
``wbc bench --help`` works without this harness), which then calls :func:`bench`.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

from wbc.blas import set_blas_threads
from wbc.jsonable import plain
from wbc.robot.loader import load_robot

from .closed_loop import sim_loop
from .floor import floor_talos
from .machine import machine_info, svd_probe
from .options import BACKENDS, DEFAULT_CYCLES, FULL_BUDGET, QUICK_BUDGET
from .peers import placo_dynamics, placo_kinematics
from .report import HEADER, case_line, fmt_floor, fmt_placo, fmt_scaling, fmt_sim_loop, results_markdown
from .scaling import plot_scaling, scaling
from .timing import main_cases
from .trajectory import DT

WARMUP = 200
QUICK_CYCLES, QUICK_WARMUP = 100, 20
CHAIN_NV = (12, 18, 24, 36, 48, 72, 96, 120, 156)
QUICK_CHAIN_NV = (12, 36, 96, 156)
LEVELS = tuple(range(1, 11))
QUICK_LEVELS = (1, 2, 4, 7, 10)


def run(cycles: int = DEFAULT_CYCLES, warmup: int = WARMUP, backends=BACKENDS, robots=("talos", "tiago"),
        floor: bool = True, peer: bool = True, sim: bool = True, scaling_nv=CHAIN_NV, scaling_levels=LEVELS,
        scaling_cycles: int = 300, scaling_warmup: int = 30, budget_s: float | None = None, svd_reps: int = 20,
        progress: Callable[[str], None] | None = None) -> dict:
    """The whole benchmark as a dict (what ``--json`` writes). ``budget_s``: wall-time
    budget per case (see :func:`.timing.run_case`)."""
    t_start = time.perf_counter()
    say = progress or (lambda s: None)
    res: dict = {"machine": machine_info()}
    res["machine"]["svd_ms"] = svd_probe(reps=svd_reps) if svd_reps else None
    loaded = {name: load_robot(name) for name in robots}
    res["settings"] = {"cycles": cycles, "warmup": warmup, "dt": DT, "backends": list(backends),
                       "budget_s_per_case": budget_s}
    say(HEADER)
    res["cases"] = main_cases(loaded, list(backends), cycles, warmup, on_case=lambda c: say(case_line(c)),
                              budget_s=budget_s)
    talos = loaded.get("talos")
    if floor and talos is not None:
        fl = floor_talos(talos, min(cycles, 500), min(warmup, 50))
        res["floor_ms"] = {"talos": fl["sum"], "talos_parts": fl}
        say("floor: " + fmt_floor(fl))
    if sim and talos is not None:
        res["sim_loop"] = sim_loop(duration=1.0 if cycles < 1000 else 5.0)
        for ln in fmt_sim_loop(res["sim_loop"]):
            say(ln)
    if peer and talos is not None:
        try:
            pd = placo_dynamics(talos, cycles, warmup)
        except Exception as exc:
            pd = {"missing": f"{type(exc).__name__}: {exc}"}
        try:
            pk = placo_kinematics(talos)
        except Exception as exc:
            pk = {"missing": f"{type(exc).__name__}: {exc}"}
        dyn = pd["solve"]["median_ms"] if "solve" in pd else None
        # "talos": the key, the DynamicsSolver on the same stack (the peer of the cases)
        res["placo_ms"] = {"talos": dyn, "talos_dynamics": dyn, "talos_kinematics": pk.get("solve_median_ms")}
        res["placo"] = {"talos_dynamics": pd, "talos_kinematics": pk}
        for ln in fmt_placo(pd, pk):
            say(ln)
    if scaling_nv or scaling_levels:
        res["scaling"] = scaling(talos, scaling_nv, scaling_levels, scaling_cycles, scaling_warmup, progress=say,
                                 budget_s=budget_s)
        for ln in fmt_scaling(res["scaling"]):
            say(ln)
    try:
        res["machine"]["load_average_end"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    res["wall_s"] = time.perf_counter() - t_start
    return res


def backends_of(values) -> list[str]:
    """``--backends`` values (comma or space separated) as a list of names; None: :data:`BACKENDS`."""
    if values is None:
        return list(BACKENDS)
    out = []
    for v in values:
        out += [b for b in v.replace(",", " ").split() if b]
    return out


def command(args) -> str:
    """The shortest ``wbc bench ...`` command line that gives ``args``."""
    parts = ["wbc", "bench"]
    if args.quick:
        parts.append("--quick")
    if args.cycles not in (None, DEFAULT_CYCLES):
        parts += ["--cycles", str(args.cycles)]
    if backends_of(args.backends) != list(BACKENDS):
        parts += ["--backends", ",".join(backends_of(args.backends))]
    if args.out_dir is not None:
        parts += ["--out-dir", args.out_dir]
    if args.json:
        parts += ["--json", args.json]
    if args.budget is not None:
        parts += ["--budget", f"{args.budget:g}"]
    if args.blas_threads is not None:
        parts += ["--blas-threads", str(args.blas_threads)]
    return " ".join(parts)


def bench(args) -> int:
    """``wbc bench`` with the parsed ``args`` (:func:`wbc.cli.bench.add_parser`): runs
    :func:`run`, prints progress, writes ``results.md``, ``scaling.png`` and ``--json``;
    returns 1 if a case failed, else 0."""
    t0 = time.perf_counter()
    if args.cycles is None:
        args.cycles = DEFAULT_CYCLES
    if args.blas_threads is not None:
        set_blas_threads(args.blas_threads)
    backends = backends_of(args.backends)
    unknown = [b for b in backends if b not in BACKENDS]
    if unknown:
        print(f"note: back-ends {unknown} are not among {list(BACKENDS)}; trying them anyway", file=sys.stderr)
    if args.quick:
        kw = dict(cycles=min(args.cycles, QUICK_CYCLES), warmup=QUICK_WARMUP, scaling_nv=QUICK_CHAIN_NV,
                  scaling_levels=QUICK_LEVELS, scaling_cycles=40, scaling_warmup=10, svd_reps=3,
                  budget_s=QUICK_BUDGET if args.budget is None else args.budget)
    else:
        kw = dict(cycles=args.cycles, warmup=WARMUP, budget_s=FULL_BUDGET if args.budget is None else args.budget)

    def say(line: str) -> None:
        print(f"[{time.perf_counter() - t0:6.1f} s] {line}", flush=True)

    res = run(backends=backends, progress=say, **kw)
    res["command"] = command(args)
    res["settings"]["quick"] = bool(args.quick)
    out_dir = Path(args.out_dir if args.out_dir is not None else "benchmarks")
    # --quick leaves the full run's files alone unless an output directory is named
    if not args.quick or args.out_dir is not None:
        plot_scaling(res["scaling"], out_dir / "scaling.png")
    res["wall_s"] = time.perf_counter() - t0
    if not args.quick:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "results.md").write_text(results_markdown(res))
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(res, indent=1, default=json_default) + "\n")
    failed = [c for c in res["cases"] if "error" in c]
    print(f"done in {res['wall_s']:.1f} s" + (f"; {len(failed)} case(s) failed" if failed else ""))
    return 1 if failed else 0


def json_default(o):
    """numpy values as plain JSON (:func:`wbc.jsonable.plain`), anything else as its text."""
    try:
        return plain(o)
    except TypeError:
        return str(o)
