"""Real-time factor and control-cycle time of ``wbc run SCENARIO``: live with the page open in
headless Chromium (drawing at 30 fps) against headless, in alternated runs, with what the control
process's thread and the machine did meanwhile.

    python benchmarks/live_view_rtf.py [--scenario talos_reach ...] [--pairs 3] [--duration 4]
        [--chromium chromium] [--pin] [--nice-browser] [--scale 1] [--window 800,600]

Each pair, per scenario: one headless run (``--headless``), one live run (``--wait``: the run
starts once the page has connected; Chromium is killed after the run). Printed per run: the
real-time factor, the control cycle's median and p99 (ms: the solve, as the metrics time it), and
``/proc/loadavg``; from a probe inside the control process (this file run as ``--child``: it wraps
``ScenarioRun.cycle``, the same wrapper in both runs) the control thread's CPU time per cycle (µs,
mean), the share of cycles in which it was preempted (an involuntary context switch,
``getrusage(RUSAGE_THREAD)``) or waited (a voluntary one: a lock, the interpreter lock, a
sleep), the slow solves (> 2 ms) and how many of them were preempted, the minor page faults in
the cycles, the control process's other threads and their CPU time; from ``/proc/stat`` over the
run, the machine's busy and steal time (% of both CPUs); for a live run the drawing process's
frames, wall time per frame and CPU time, Chromium's CPU time (all its processes), the control
process's CPU time and its publish time per snapshot. Then the ranges. The results go in
benchmarks/live_view.md by hand.

``--pin``: the control process on CPU 0, the drawing process and Chromium on CPU 1 (both runs).
``--shadows on|off``: the page's lights cast shadows or not (``PageOptions.shadows``).
``--drawing-nice N``: the drawing process (and its session's autogroup) at nice N.
``--nice-browser``: Chromium's session (its autogroup: with ``kernel.sched_autogroup_enabled``
a process's nice value counts only inside its session) at nice 19 from the loop's first cycle (the
page has loaded by then; niced earlier it may never load on a loaded machine). ``--scale``: Chromium's device
scale factor; ``--window``: its window size (the canvas it renders, in CSS pixels).
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
         "--no-first-run", "--disable-background-networking", "--disable-breakpad", "--disable-crash-reporter"]
DEVTOOLS_PORT = 9290
# the page's frames: draw calls on WebGL contexts, one frame per task that issues any (a render),
# each frame's wall time (ms since the epoch) kept
COUNT_FRAMES = """(function () {
  window.wbcFrames = []; var inFrame = false;
  [window.WebGLRenderingContext, window.WebGL2RenderingContext].forEach(function (C) {
    if (!C) { return; }
    ["drawElements", "drawArrays", "drawElementsInstanced", "drawArraysInstanced", "drawRangeElements"].forEach(
      function (name) {
        var f = C.prototype[name];
        if (!f) { return; }
        C.prototype[name] = function () {
          if (!inFrame) {
            inFrame = true; window.wbcFrames.push(performance.timeOrigin + performance.now());
            queueMicrotask(function () { inFrame = false; });
          }
          return f.apply(this, arguments);
        };
      });
  });
})();"""
SLOW_S = 2e-3           # a solve slower than this is "slow" (headless p99 on an idle machine: 0.6-0.9 ms)


def load() -> str:
    return Path("/proc/loadavg").read_text().split()[0]


def cpu_times() -> list[int]:
    """The machine's /proc/stat 'cpu' line: user nice system idle iowait irq softirq steal (ticks)."""
    return [int(x) for x in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:9]]


def _children(pid: int) -> list[int]:
    """The child processes of ``pid`` (Linux /proc)."""
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _pid_cpu_s(pid: int) -> float:
    """CPU time (s, user + system) of process ``pid`` (0 if gone)."""
    try:
        f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def _session_cpu_s(sid: int) -> float:
    """CPU time (s, user + system) of the live processes of session ``sid`` (Chromium's)."""
    total = 0
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            f = (p / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(f[3]) == sid:        # fields after the name: state ppid pgrp session ... utime(11) stime(12)
            total += int(f[11]) + int(f[12])
    return total / os.sysconf("SC_CLK_TCK")


# ---------------------------------------------------------------------------------------- probe
def child(probe_out: str, argv: list[str]) -> int:
    """Run ``wbc`` with ``argv`` in this process, the control thread's counters recorded per
    cycle (the same wrapper for headless and live runs) and written to ``probe_out``."""
    import resource
    import threading

    import numpy as np

    from wbc.cli.main import main as wbc_main
    from wbc.runner.loop import ScenarioRun

    rec: dict = {"cpu": [], "wall": [], "inv": [], "vol": [], "minflt": [], "solve": []}
    start: dict = {}
    tick = os.sysconf("SC_CLK_TCK")

    def threads() -> dict:
        out = {}
        for t in Path("/proc/self/task").iterdir():
            try:
                name = (t / "comm").read_text().strip()
                f = (t / "stat").read_text().rsplit(")", 1)[1].split()
                out[f"{t.name} {name}"] = (int(f[11]) + int(f[12])) / tick
            except OSError:
                pass
        return out

    if os.environ.get("LIVE_VIEW_SHADOWS"):        # --shadows: the page's lights cast shadows or not
        import wbc.viz.live as live_mod

        spec_of = live_mod.view_spec
        live_mod.view_spec = lambda *a, **k: {**spec_of(*a, **k), "shadows": os.environ["LIVE_VIEW_SHADOWS"] == "on"}
    cycle = ScenarioRun.cycle
    metrics = ScenarioRun.metrics

    browser_pid_file = Path(probe_out).with_suffix(".browser")

    def others() -> dict:
        """CPU s of the drawing process (this one's children) and of Chromium (its session)."""
        out = {"drawing": sum(_pid_cpu_s(c) for c in _children(os.getpid()))}
        if browser_pid_file.exists():
            out["browser"] = _session_cpu_s(int(browser_pid_file.read_text()))
        return out

    def probed_cycle(self, k):
        if not start:
            nice = os.environ.get("LIVE_VIEW_NICE_BROWSER")
            if nice and browser_pid_file.exists():      # now, once the page has loaded: it would starve loading
                Path(f"/proc/{int(browser_pid_file.read_text())}/autogroup").write_text(nice)
            start.update(epoch=time.time(), threads=threads(), others=others(), cpu=time.process_time(),
                         thread_cpu=time.thread_time(),
                         wall=time.perf_counter(), ru=resource.getrusage(resource.RUSAGE_THREAD))
        r0 = resource.getrusage(resource.RUSAGE_THREAD)
        c0, w0 = time.thread_time_ns(), time.perf_counter_ns()
        ok = cycle(self, k)
        w1, c1 = time.perf_counter_ns(), time.thread_time_ns()
        r1 = resource.getrusage(resource.RUSAGE_THREAD)
        rec["cpu"].append(c1 - c0)
        rec["wall"].append(w1 - w0)
        rec["inv"].append(r1.ru_nivcsw - r0.ru_nivcsw)
        rec["vol"].append(r1.ru_nvcsw - r0.ru_nvcsw)
        rec["minflt"].append(r1.ru_minflt - r0.ru_minflt)
        rec["solve"].append(float(self.cycle_times[k]))
        return ok

    def probed_metrics(self):
        if start:
            ru = resource.getrusage(resource.RUSAGE_THREAD)
            t0, t1 = start["threads"], threads()
            o0, o1 = start["others"], others()
            a = {k: np.array(v[1:], dtype=float) for k, v in rec.items()}      # cycle 0 compiles/loads
            slow = a["solve"] > SLOW_S
            Path(probe_out).write_text(json.dumps({
                "cycles": int(a["cpu"].size),
                "cycle_cpu_us": float(a["cpu"].mean() * 1e-3), "cycle_wall_us": float(a["wall"].mean() * 1e-3),
                "cycle_cpu_p99_us": float(np.percentile(a["cpu"], 99) * 1e-3),
                "preempted_share": float(np.mean(a["inv"] > 0)), "waited_share": float(np.mean(a["vol"] > 0)),
                "slow_solves": int(slow.sum()), "slow_preempted": int(np.sum(slow & (a["inv"] > 0))),
                "slow_waited": int(np.sum(slow & (a["vol"] > 0) & (a["inv"] == 0))),
                "minflt_per_cycle": float(a["minflt"].mean()),
                "loop_thread_cpu_s": time.thread_time() - start["thread_cpu"],
                "loop_process_cpu_s": time.process_time() - start["cpu"],
                "loop_wall_s": time.perf_counter() - start["wall"],
                "loop_inv": ru.ru_nivcsw - start["ru"].ru_nivcsw, "loop_vol": ru.ru_nvcsw - start["ru"].ru_nvcsw,
                "loop_minflt": ru.ru_minflt - start["ru"].ru_minflt, "loop_majflt": ru.ru_majflt - start["ru"].ru_majflt,
                "python_threads": [t.name for t in threading.enumerate()],
                "threads_cpu_s": {k: round(t1[k] - t0.get(k, 0.0), 2) for k in t1},
                "others_cpu_s": {k: o1[k] - o0[k] for k in o1 if k in o0},
                "switchinterval_s": sys.getswitchinterval(), "main_tid": threading.get_native_id(),
                "loop_epoch_s": [start["epoch"], time.time()]}))
        return metrics(self)

    ScenarioRun.cycle = probed_cycle            # type: ignore[method-assign]
    ScenarioRun.metrics = probed_metrics        # type: ignore[method-assign]
    return wbc_main(argv)


class Page:
    """The page's tab over the DevTools protocol: the frame counter installed before the page
    loads (:data:`COUNT_FRAMES`), then read."""

    def __init__(self, port: int) -> None:
        import urllib.request

        from websockets.sync.client import connect

        for _ in range(300):
            try:
                tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json"))
                break
            except OSError:
                time.sleep(0.1)
        self.ws = connect(next(t for t in tabs if t["type"] == "page")["webSocketDebuggerUrl"], max_size=None)
        self.id = 0

    def call(self, method: str, **params):
        self.id += 1
        self.ws.send(json.dumps({"id": self.id, "method": method, "params": params}))
        while True:
            r = json.loads(self.ws.recv(timeout=120))
            if r.get("id") == self.id:
                return r.get("result", {})

    def frame_times(self) -> list[float]:
        """The wall times (s since the epoch) of the frames the page has rendered."""
        ms = self.call("Runtime.evaluate", expression="window.wbcFrames || []", returnByValue=True)["result"]
        return [1e-3 * t for t in ms.get("value", [])]


# ---------------------------------------------------------------------------------------- runs
def one(scenario: str, live: bool, args, work: Path) -> dict:
    tag = f"{'live' if live else 'headless'}_{time.monotonic_ns()}"
    out, probe = work / f"m_{tag}.json", work / f"p_{tag}.json"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(probe), "--",
           "run", scenario, "--duration", str(args.duration), "--metrics", str(out), "--fps", str(args.fps)]
    cmd += ["--wait", "--port", "8290", *args.page] if live else ["--headless"]
    env = dict(os.environ, PYTHONPATH=str(ROOT), **({"LIVE_VIEW_SHADOWS": args.shadows} if args.shadows else {}),
               **({"LIVE_VIEW_NICE_BROWSER": "19"} if args.nice_browser else {}))
    pre = ["taskset", "-c", "0"] if args.pin else []      # --pin: the control process on CPU 0, the page's on CPU 1
    proc = subprocess.Popen(pre + cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True)
    browser, browser_cpu, stat0, page = None, None, None, None
    frames: dict = {}       # the page's frame times
    try:
        if live:
            assert proc.stdout is not None
            for line in proc.stdout:
                if "browser view at" in line:
                    url = line.split("browser view at ")[1].split()[0]
                    for c in _children(proc.pid):       # the drawing process
                        if args.pin:
                            os.sched_setaffinity(c, {1})
                        if args.drawing_nice is not None:   # its session's autogroup and itself
                            Path(f"/proc/{c}/autogroup").write_text(str(args.drawing_nice))
                            os.setpriority(os.PRIO_PROCESS, c, args.drawing_nice)
                    w, h = args.window.split(",")
                    browser = subprocess.Popen([*(["taskset", "-c", "1"] if args.pin else []), args.chromium, *FLAGS,
                                                f"--window-size={w},{h}", f"--force-device-scale-factor={args.scale}",
                                                f"--user-data-dir={work / 'profile'}",
                                                f"--remote-debugging-port={DEVTOOLS_PORT}", "about:blank"],
                                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                               start_new_session=True)
                    page = Page(DEVTOOLS_PORT)
                    page.call("Page.enable")
                    page.call("Page.addScriptToEvaluateOnNewDocument", source=COUNT_FRAMES)
                    page.call("Page.navigate", url=url)
                    Path(probe).with_suffix(".browser").write_text(str(browser.pid))
                    break
            stat0 = cpu_times()
            for line in proc.stdout:            # the run's progress; the metrics line at its end
                if line.startswith("metrics written") and browser is not None:
                    browser_cpu = _session_cpu_s(browser.pid)
                    if page is not None:
                        frames["times"] = page.frame_times()
        else:
            stat0 = cpu_times()
        proc.communicate(timeout=600)
        stat1 = cpu_times()
    finally:
        if page is not None:
            page.ws.close()
        if browser is not None:
            if browser_cpu is None:
                browser_cpu = _session_cpu_s(browser.pid)
            os.killpg(browser.pid, signal.SIGKILL)
            browser.wait()
            for p in Path("/proc").iterdir():       # its crash handlers: sessions of their own, our profile's path
                try:
                    if p.name.isdigit() and str(work / "profile").encode() in (p / "cmdline").read_bytes():
                        os.kill(int(p.name), signal.SIGKILL)
                except OSError:
                    pass
    m = json.loads(out.read_text())
    d = [b - a for a, b in zip(stat0, stat1)]
    total = max(sum(d), 1)
    p = json.loads(probe.read_text()) if probe.exists() else {}
    return {"scenario": scenario, "live": live, "rtf": m["real_time_factor"], "median_ms": m["cycle_time"]["median"] * 1e3,
            "p99_ms": m["cycle_time"]["p99"] * 1e3, "load": load(), "view": m.get("live_view"), "probe": p,
            "busy_pct": 100.0 * (total - d[3] - d[4]) / total, "steal_pct": 100.0 * d[7] / total,
            "browser_cpu_s": browser_cpu,
            "page_frames": page_frames(frames.get("times"), p.get("loop_epoch_s")),
            "page_times": [round(t - p["loop_epoch_s"][0], 3) for t in frames.get("times", [])[:3] + frames.get("times", [])[-3:]]
            if p.get("loop_epoch_s") else None, "page_total": len(frames.get("times", []))}


def page_frames(times: list[float] | None, loop: list[float] | None) -> int | None:
    """The page's frames rendered during the loop (wall times between its first and last cycle)."""
    if times is None or loop is None:
        return None
    return sum(loop[0] <= t <= loop[1] for t in times)


def show(r: dict) -> str:
    p, v = r["probe"], r["view"]
    s = (f"{r['scenario']:<22} {'live    ' if r['live'] else 'headless'} rtf {r['rtf']:.3f}  cycle median "
         f"{r['median_ms']:.3f} ms  p99 {r['p99_ms']:.3f} ms  load {r['load']}  machine busy {r['busy_pct']:.0f} % "
         f"steal {r['steal_pct']:.1f} %")
    if p:
        other = {k: c for k, c in p["threads_cpu_s"].items() if c > 0 and k.split()[0] != str(p.get("main_tid", ""))}
        s += (f"\n    probe: thread CPU/cycle {p['cycle_cpu_us']:.0f} µs (p99 {p['cycle_cpu_p99_us']:.0f}), wall/cycle "
              f"{p['cycle_wall_us']:.0f} µs; cycles preempted {100 * p['preempted_share']:.1f} %, waited "
              f"{100 * p['waited_share']:.1f} %; slow solves (> 2 ms) {p['slow_solves']}, preempted {p['slow_preempted']}, "
              f"waited {p['slow_waited']}; minor faults/cycle {p['minflt_per_cycle']:.2f}; loop: thread CPU "
              f"{p['loop_thread_cpu_s']:.2f} s, process CPU {p['loop_process_cpu_s']:.2f} s, wall {p['loop_wall_s']:.2f} s, "
              f"invol. switches {p['loop_inv']}, vol. {p['loop_vol']}; Python threads {p['python_threads']}; "
              f"threads with CPU {other}; during the loop, CPU s of {p.get('others_cpu_s')}")
    if v:
        s += (f"\n    view: drawn {v['frames_drawn']} frames, {v['draw_ms_mean']:.2f} ms each; CPU s: drawing process "
              f"{v['drawing_cpu_s']:.2f}, Chromium {r['browser_cpu_s']:.2f}, control process {v['control_cpu_s']:.2f}; "
              f"publish {v['publish_ms_mean']:.3f} ms")
        o = p.get("others_cpu_s", {}) if p else {}
        if r.get("page_frames") is not None:
            b = o.get("browser")
            wall = p["loop_wall_s"]
            s += (f"\n    page: {r['page_frames']} frames rendered during the loop ({wall:.2f} s: "
                  f"{r['page_frames'] / max(wall, 1e-9):.1f}/s)"
                  + (f"; Chromium {b:.2f} s CPU in the loop, {1e3 * b / max(r['page_frames'], 1):.0f} ms per "
                     "rendered frame" if b is not None else "")
                  + f" [{r.get('page_total')} in all, first and last at {r.get('page_times')} s from the loop's start]")
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", nargs="+", default=["talos_reach"])
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--chromium", default=shutil.which("chromium") or "chromium")
    ap.add_argument("--pin", action="store_true", help="control process on CPU 0; drawing process and Chromium on "
                    "CPU 1 (both runs): whether what is left is CPU sharing, not waiting")
    ap.add_argument("--nice-browser", action="store_true", help="Chromium's session (autogroup) at nice 19")
    ap.add_argument("--shadows", choices=("on", "off"), help="the page's lights cast shadows (default: the page's)")
    ap.add_argument("--drawing-nice", type=int, help="set the drawing process's (and its autogroup's) nice value "
                    "(default: its own, wbc.viz.drawing.NICE)")
    ap.add_argument("--page", action="append", default=[], metavar="ARG", help="one more `wbc run` argument for "
                    "the live run, e.g. --page=--mesh-cell=0 (the page's meshes; repeat it for more)")
    ap.add_argument("--scale", type=float, default=1.0, help="Chromium's device scale factor")
    ap.add_argument("--window", default="800,600", help="Chromium's window size W,H (CSS pixels)")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for _ in range(args.pairs):
            for sc in args.scenario:
                for live in (False, True):
                    r = one(sc, live, args, Path(d))
                    rows.append(r)
                    print(show(r), flush=True)
    for sc in args.scenario:
        for live in (False, True):
            sel = [r for r in rows if r["live"] == live and r["scenario"] == sc]
            print(f"{sc} {'live' if live else 'headless'}: rtf {min(r['rtf'] for r in sel):.3f}-"
                  f"{max(r['rtf'] for r in sel):.3f}, p99 {min(r['p99_ms'] for r in sel):.3f}-"
                  f"{max(r['p99_ms'] for r in sel):.3f} ms, load {min(r['load'] for r in sel)}-{max(r['load'] for r in sel)}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--child":      # the control process, probed (see child)
        sys.exit(child(sys.argv[2], sys.argv[4:]))
    main()
