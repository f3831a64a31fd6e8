"""Speed-up and per-case overhead of `wbc sweep`'s executors on this machine.

    nice python benchmarks/sweep_scaling.py [--cases 8] [--duration 0.5] [--no-ray]

The same cases (talos_push, hqp, push magnitudes × friction, ``--duration`` s simulated
each) run in this process one after the other (:func:`wbc.sweep.worker.execute`: the
baseline, no executor), then on the local pool and on Ray with 1 and 2 workers. For each
executor: its start-up (the pool's processes importing wbc, or ``ray.init``) and a
warm-up sweep (each worker's first case loads the robot and numba's cached kernels)
are timed apart; then a sweep of the real cases (speed-up = baseline / its wall time)
and one of as many near-empty cases (2 ms simulated: scenario build, a few cycles,
shipping the row), whose time per case × workers minus the baseline's is the executor's
overhead per case. Writes ``benchmarks/sweep_scaling.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent


def _spec(tmp: Path, n: int, duration: float):
    from wbc.sweep.spec import load_spec

    forces = [20.0 + 160.0 * i / max(1, n // 2 - 1) for i in range(max(1, n // 2))]
    p = tmp / f"scaling_{n}_{duration:g}.yaml"
    p.write_text(yaml.safe_dump({"base": "talos_push", "set": {"duration": duration, "pushes[0].start": 0.0,
                                                                "solver.type": "hqp"},
                                 "axes": {"pushes[0].force@magnitude": forces, "environment[0].mu": [0.6, 0.9]},
                                 "timeout": 600}))
    return load_spec(p)


def _serial(spec) -> float:
    """Wall time (s) of the spec's cases run one after the other in this process."""
    from wbc.sweep.cases import static_cases
    from wbc.sweep.worker import execute

    cases = static_cases(spec)
    execute(cases[0].payload())                 # robot and kernels loaded: a warm worker
    t0 = time.perf_counter()
    for c in cases:
        assert execute(c.payload())["status"] in ("ok", "fell")
    return time.perf_counter() - t0


def _sweep(spec, tmp: Path, tag: str, **kw) -> float:
    """Wall time (s) of a fresh sweep of ``spec``."""
    from wbc.sweep.engine import run_sweep

    t0 = time.perf_counter()
    res = run_sweep(spec, out_dir=tmp / tag, progress=False, **kw)
    wall = time.perf_counter() - t0
    assert res.ran == len(res.records) and res.count("ok") + res.count("fell") == res.ran, tag
    return wall


def _executor(kind: str, workers: int):
    """A started executor and its start-up time (s)."""
    t0 = time.perf_counter()
    if kind == "local":
        from wbc.sweep.local import LocalPool

        ex = LocalPool(workers, 600)
        while not all(s.ready for s in ex._slots):
            ex.wait(0.02)
    else:
        import ray

        from wbc.sweep.ray_pool import RayPool

        # workers at the driver's priority, like the pool's (Ray's default is nice 15)
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                 _system_config={"worker_niceness": 0})
        ex = RayPool(timeout=600)
    return ex, time.perf_counter() - t0


def _close(kind: str, ex) -> None:
    ex.close()
    if kind == "ray":
        import ray

        ray.shutdown()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=8)
    ap.add_argument("--duration", type=float, default=0.5, help="simulated s per case")
    ap.add_argument("--empty", type=int, default=40, help="near-empty cases for the overhead")
    ap.add_argument("--repeats", type=int, default=3, help="repetitions (the minimum is kept)")
    ap.add_argument("--no-ray", action="store_true")
    args = ap.parse_args()
    configs = [("local", 1), ("local", 2)] + ([] if args.no_ray else [("ray", 1), ("ray", 2)])
    runs: dict = {c: [] for c in [("in-process loop", 1), *configs]}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        real, empty = _spec(tmp, args.cases, args.duration), _spec(tmp, args.empty, 0.002)
        warm = _spec(tmp, 4, 0.001)
        for rep in range(args.repeats):         # interleaved, the minimum kept: the machine is shared
            runs[("in-process loop", 1)].append((0.0, 0.0, _serial(real), _serial(empty)))
            for kind, w in configs:
                ex, start = _executor(kind, w)
                try:
                    warm_s = _sweep(warm, tmp, f"warm{kind}{w}.{rep}", executor=ex)
                    wall = _sweep(real, tmp, f"{kind}{w}.{rep}", executor=ex)
                    wall_empty = _sweep(empty, tmp, f"empty{kind}{w}.{rep}", executor=ex)
                finally:
                    _close(kind, ex)
                runs[(kind, w)].append((start, warm_s, wall, wall_empty))
                print(kind, w, rep, runs[(kind, w)][-1], flush=True)
    base_real = min(r[2] for r in runs[("in-process loop", 1)])
    base_empty = min(r[3] for r in runs[("in-process loop", 1)])
    rows = []
    for (kind, w), rs in runs.items():
        start, warm_s, wall, wall_empty = (min(r[i] for r in rs) for i in range(4))
        rows.append({"executor": kind, "workers": w, "startup_s": start, "warmup_s": warm_s, "sweep_s": wall,
                     "speedup": base_real / wall, "empty_sweep_s": wall_empty,
                     "overhead_per_case_s": (wall_empty * w - base_empty) / args.empty})
    with (HERE / "sweep_scaling.csv").open("w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows)
    load = os.getloadavg()
    lines = ["# `wbc sweep` executors: speed-up and overhead", "",
             f"Reproduce: `nice python benchmarks/sweep_scaling.py --cases {args.cases} --duration {args.duration:g} "
             f"--empty {args.empty} --repeats {args.repeats}` ({os.cpu_count()} cores, shared with other users: load "
             f"average {load[0]:.1f} at the end; each figure the minimum of {args.repeats} interleaved repetitions).",
             "",
             f"{args.cases} cases of talos_push (hqp, {args.duration:g} s simulated each; the loop in this process "
             f"takes {base_real / args.cases:.2f} s per case) and {args.empty} near-empty cases (2 ms simulated: "
             f"scenario build, a few cycles, the row shipped back; {1000 * base_empty / args.empty:.0f} ms per case "
             "in the loop). `start-up`: the pool's processes importing wbc, or `ray.init`; `warm-up`: a first sweep "
             "of 4 empty cases (each worker loads the robot and numba's cached kernels); `sweep`: the real cases, "
             "`speed-up` = loop / sweep; `overhead/case` = (empty-case sweep × workers − loop) / cases.", "",
             "| executor | workers | start-up s | warm-up s | sweep s | speed-up | empty-case sweep s | "
             "overhead/case s |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['executor']} | {r['workers']} | {r['startup_s']:.2f} | {r['warmup_s']:.2f} | "
                     f"{r['sweep_s']:.2f} | {r['speedup']:.2f} | {r['empty_sweep_s']:.2f} | "
                     f"{r['overhead_per_case_s']:.3f} |")
    (HERE / "sweep_scaling.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
