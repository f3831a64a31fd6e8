"""Real-time factor and control-cycle time of ``wbc run talos_reach``: live with the page open in
headless Chromium (drawing at 30 fps) against headless, in alternated runs.

    python benchmarks/live_view_rtf.py [--pairs 3] [--duration 4] [--chromium chromium] [--pin]

Each pair: one headless run (``--headless``), one live run (``--wait``: the run starts once the
page has connected; Chromium is killed after the run). Prints, per run, the real-time factor,
the control cycle's median and p99 (ms), and ``uptime``'s load; for a live run also the drawing
process's frames, wall time per frame and CPU time, the control process's CPU time and its
publish time per snapshot; then the ranges. The results
go in benchmarks/live_view.md by hand.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
         "--no-first-run", "--disable-background-networking", "--window-size=800,600"]


def load() -> str:
    return Path("/proc/loadavg").read_text().split()[0]


def _children(pid: int) -> list[int]:
    """The child processes of ``pid`` (Linux /proc)."""
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def one(live: bool, duration: float, chromium: str, work: Path, pin: bool = False) -> dict:
    out = work / f"m_{'live' if live else 'headless'}_{time.monotonic_ns()}.json"
    cmd = [sys.executable, "-m", "wbc.cli", "run", "talos_reach", "--duration", str(duration), "--metrics", str(out)]
    cmd += ["--wait", "--port", "8290"] if live else ["--headless"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    pre = ["taskset", "-c", "0"] if pin else []      # --pin: the control process on CPU 0, the page's on CPU 1
    proc = subprocess.Popen(pre + cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    browser = None
    try:
        if live:
            for line in proc.stdout:
                if "browser view at" in line:
                    url = line.split("browser view at ")[1].split()[0]
                    if pin:
                        for child in _children(proc.pid):       # the drawing process
                            os.sched_setaffinity(child, {1})
                    browser = subprocess.Popen([*(["taskset", "-c", "1"] if pin else []), chromium, *FLAGS,
                                                f"--user-data-dir={work / 'profile'}", url],
                                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                               start_new_session=True)
                    break
        proc.communicate(timeout=600)
    finally:
        if browser is not None:
            os.killpg(browser.pid, signal.SIGKILL)
            browser.wait()
    m = json.loads(out.read_text())
    return {"live": live, "rtf": m["real_time_factor"], "median_ms": m["cycle_time"]["median"] * 1e3,
            "p99_ms": m["cycle_time"]["p99"] * 1e3, "load": load(), "view": m.get("live_view")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--chromium", default=shutil.which("chromium") or "chromium")
    ap.add_argument("--pin", action="store_true", help="control process on CPU 0; drawing process and Chromium on "
                    "CPU 1 (both runs): whether what is left is CPU sharing, not waiting")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for _ in range(args.pairs):
            for live in (False, True):
                r = one(live, args.duration, args.chromium, Path(d), args.pin)
                rows.append(r)
                print(f"{'live    ' if live else 'headless'} rtf {r['rtf']:.3f}  cycle median {r['median_ms']:.3f} ms  "
                      f"p99 {r['p99_ms']:.3f} ms  load {r['load']}"
                      + (f"  drawn {r['view']['frames_drawn']} frames, {r['view']['draw_ms_mean']:.2f} ms each; CPU s: "
                         f"drawing process {r['view']['drawing_cpu_s']:.2f}, control process {r['view']['control_cpu_s']:.2f}; "
                         f"publish {r['view']['publish_ms_mean']:.3f} ms" if r["view"] else ""), flush=True)
    for live in (False, True):
        sel = [r for r in rows if r["live"] == live]
        print(f"{'live' if live else 'headless'}: rtf {min(r['rtf'] for r in sel):.3f}-{max(r['rtf'] for r in sel):.3f}, "
              f"p99 {min(r['p99_ms'] for r in sel):.3f}-{max(r['p99_ms'] for r in sel):.3f} ms")


if __name__ == "__main__":
    main()
