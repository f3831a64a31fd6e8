"""Soak of talos_balance under random pushes: memory, foot drift and loop period over a long run.

    PYTHONPATH=. python -m tests.reliability.soak pinocchio 600      # 10 simulated minutes

The scenario (its ±5 cm CoM sway at 0.5 Hz) plus a push every 2-4 s (seeded): 20-40 N,
horizontal, random direction, 0.1 s at the torso. Sampled once per simulated second by the
runner's callback: the process's resident set (RSS, /proc/self/statm), the live
Python-allocator blocks (``sys.getallocatedblocks``: every Python object and array header,
so a per-cycle leak of one object shows as ≥ 1 block per cycle) and the bytes malloc has
handed out (glibc's ``mallinfo2``: what C and C++ extensions leak, which RSS shows only once
the heap's free pool is used up; pinocchio 4.1's DelassusOperatorDense binding leaked 32 B
per simulator step, RSS +5.6 % over 10 minutes, flat for the first 40-60 s). Every 0.1 s: the
displacement of the soles' corner points from where they started (mm). Every cycle: the
loop's wall period (callback to callback: measure, solve, step, metrics), for its p99 per
window. Nothing the probe keeps grows: its arrays are filled before the first cycle.
"""

from __future__ import annotations

import ctypes
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

import wbc
from wbc.runner.loop import run
from wbc.scenario.examples import SCENARIOS_DIR

_PAGE = os.sysconf("SC_PAGE_SIZE")


class _MallInfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                               "fsmblks", "uordblks", "fordblks", "keepcost")]


try:
    _mallinfo2 = ctypes.CDLL("libc.so.6").mallinfo2
    _mallinfo2.restype = _MallInfo2
except (OSError, AttributeError):        # not glibc >= 2.33
    _mallinfo2 = None


def heap() -> float:
    """Bytes malloc has handed out and not had back (in its arena and mmapped); NaN without glibc."""
    if _mallinfo2 is None:
        return float("nan")
    m = _mallinfo2()
    return float(m.uordblks + m.hblkhd)


def rss() -> int:
    """Resident set size of this process (bytes)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * _PAGE


def pushes(duration: float, seed: int, every=(2.0, 4.0), force=(20.0, 40.0), length: float = 0.1) -> list[dict]:
    """Scenario ``pushes:`` entries: one every U(every) s from 1 s on, |F| ~ U(force) N, horizontal."""
    rng = np.random.default_rng(seed)
    out, t = [], 1.0
    while t + length < duration:
        a, f = rng.uniform(0.0, 2.0 * np.pi), rng.uniform(*force)
        out.append({"frame": "torso", "force": [float(f * np.cos(a)), float(f * np.sin(a)), 0.0],
                    "start": round(t, 3), "duration": length})
        t += rng.uniform(*every)
    return out


def scenario(duration: float, seed: int, folder: Path) -> wbc.Scenario:
    """talos_balance for ``duration`` s with :func:`pushes`, through the schema like any scenario."""
    doc = yaml.safe_load((SCENARIOS_DIR / "talos_balance.yaml").read_text())
    doc.update(name="talos_soak", duration=duration, pushes=pushes(duration, seed))
    path = folder / "talos_soak.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return wbc.load_config(path)


def soak(simulator: str, duration: float, seed: int = 15, window: float | None = None) -> dict:
    """Run the soak; figures compare the first ``window`` s (default 60 s, or a third of a
    shorter run) with the last: memory at the end of each, foot drift, loop-period p99."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        sc = scenario(duration, seed, Path(tmp))
    window = window or min(60.0, duration / 3)
    dt = sc.dt
    n = round(duration / dt)
    per_s, per_foot = round(1.0 / dt), round(0.1 / dt)
    period = np.full(n, np.nan)
    mem = np.full((int(duration) + 1, 4), np.nan)        # t, RSS, blocks, heap
    drift = np.full(n // per_foot + 1, np.nan)
    p0: list[np.ndarray] = []
    last = [0.0]

    def probe(t, sim, sol):
        k = round(t / dt)
        now = time.perf_counter()
        period[k] = now - last[0]
        last[0] = now
        if k % per_foot == 0:
            pts = sim.point_positions()
            if not p0:
                p0.append(pts.copy())
            drift[k // per_foot] = 1e3 * np.linalg.norm(pts - p0[0], axis=1).max()
        if (k + 1) % per_s == 0:
            mem[(k + 1) // per_s] = (t + dt, rss(), sys.getallocatedblocks(), heap())

    run(sc, duration=0.01, simulator=simulator)          # compile/load the kernels first
    last[0] = time.perf_counter()
    out = run(sc, simulator=simulator, callback=probe)
    period[0] = np.nan                                   # started before the run's set-up
    w = round(window / dt)
    got = mem[~np.isnan(mem[:, 0])]
    first = got[np.searchsorted(got[:, 0], window - 1e-9)]
    end = got[-1]
    return {
        "simulator": simulator, "duration": out["duration"], "window": window, "pushes": len(sc.pushes),
        "fell": out["fell"], "solver_failures": out["solver_failures"],
        "rss_mb": [float(first[1] / 1e6), float(end[1] / 1e6)],
        "rss_growth": float(end[1] / first[1] - 1.0),
        "blocks": [int(first[2]), int(end[2])],
        "blocks_per_cycle": float((end[2] - first[2]) / max(1.0, (end[0] - first[0]) / dt)),
        "heap_bytes_per_cycle": float((end[3] - first[3]) / max(1.0, (end[0] - first[0]) / dt)),
        "drift_mm_max": float(np.nanmax(drift)),
        "drift_mm_first_window_max": float(np.nanmax(drift[: w // per_foot + 1])),
        "drift_mm_final": float(drift[~np.isnan(drift)][-1]),
        "drift_mm_per_window": [float(np.nanmax(drift[i:i + w // per_foot], initial=0.0))
                                for i in range(0, len(drift) - w // per_foot + 1, w // per_foot)],
        "slip_mm": {c: 1e3 * m["slip"] for c, m in out["contacts"].items()},
        "period_p99_ms": [1e3 * float(np.nanpercentile(period[:w], 99)),
                          1e3 * float(np.nanpercentile(period[-w:], 99))],
        "period_median_ms": 1e3 * float(np.nanmedian(period)),
        "solve_p99_ms": 1e3 * out["cycle_time"]["p99"],
    }


if __name__ == "__main__":
    figures = soak(sys.argv[1], float(sys.argv[2]))
    figures["p99_ratio_last_first"] = figures["period_p99_ms"][1] / figures["period_p99_ms"][0]
    print(json.dumps(figures, indent=1))
