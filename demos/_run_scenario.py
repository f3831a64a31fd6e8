"""Shared body of the scenario demos: run one ``wbc/data/scenarios/*.yaml`` in the browser view.

Live (Meshcat on 127.0.0.1, URL printed, real time, priority diagnostics top left)
with ``--viz`` or when a display is available; otherwise headless, writing a
self-contained HTML replay (plays offline) to ``recordings/<name>.html`` and
printing its path. ``--plot out.png`` adds the run's plots. Prints the metrics.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _summary(m: dict) -> None:
    print(f"  fell: {m['fell']}   solver failures: {m['solver_failures']}   "
          f"real-time factor: {m['real_time_factor']:.2f}")
    for name, s in m["tasks"].items():
        print(f"  {name:14s} error  rms {s['rms'] * 1e3:9.3f}  max {s['max'] * 1e3:9.3f}  "
              f"final {s['final'] * 1e3:9.3f}  (mm, mrad or mN)")
    for name, c in m["contacts"].items():
        print(f"  {name:14s} slip {c['slip'] * 1e3:.3f} mm   lifted: {c['lifted']}")
    if "support_margin_min" in m:
        print(f"  CoM margin inside the support polygon (min): {m['support_margin_min'] * 100:.1f} cm")
    if "base_lateral_velocity_max" in m:
        print(f"  lateral base velocity (max): {m['base_lateral_velocity_max']:.1e} m/s (differential drive)")
    if "glass_tilt_max" in m:
        print(f"  glass tilt (max): {m['glass_tilt_max'] * 180 / 3.141592653589793:.2f} deg   hand position error "
              f"(max): {m['hand_position_error_max'] * 1e3:.2f} mm   elbow displacement (max): "
              f"{m['elbow_displacement_max'] * 1e2:.1f} cm")
    if "normal_force_rms_error" in m:
        print(f"  normal force RMS error (after 1 s): {m['normal_force_rms_error']:.2g} N   "
              f"path error (max): {m['path_error_max'] * 1e3:.2f} mm")
    print(f"  limit violations (cycles): {m['violations']}")
    print(f"  control cycle: median {m['cycle_time']['median'] * 1e3:.2f} ms, p99 {m['cycle_time']['p99'] * 1e3:.2f} ms")


def main(scenario: str, doc: str, name: str | None = None, duration: float | None = None,
         argv: list[str] | None = None) -> int:
    """Run ``wbc/data/scenarios/<scenario>.yaml`` (see the module docstring); ``name``: the
    recording's file name (default the scenario's); ``duration``: default run length (s)."""
    name = name or scenario
    parser = argparse.ArgumentParser(description=doc.strip().split("\n")[0],
                                     epilog=f"headless replay: recordings/{name}.html")
    parser.add_argument("--viz", action="store_true",
                        help="play live in the browser (Meshcat on 127.0.0.1) even without a display")
    parser.add_argument("--solver", choices=["hqp", "projection", "weighted"],
                        help="priority solver (default: the scenario's, hqp)")
    parser.add_argument("--duration", type=float, default=duration, metavar="S",
                        help="simulated duration in s (default: "
                             + (f"{duration:g}" if duration else "the scenario's") + ")")
    parser.add_argument("--speed", type=float, default=1.0, metavar="X", help="live playback speed (default 1.0)")
    parser.add_argument("--record", default=str(ROOT / "recordings" / f"{name}.html"), metavar="FILE.html",
                        help=f"where a headless run writes its HTML replay (default recordings/{name}.html)")
    parser.add_argument("--plot", metavar="FILE.png", help="also plot the run (task errors, contact forces, torques)")
    args = parser.parse_args(argv)

    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config
    from wbc.viz import Scene, shown_frames, viewer_callback

    live = args.viz or bool(os.environ.get("DISPLAY"))
    sc = load_config(ROOT / "wbc" / "data" / "scenarios" / f"{scenario}.yaml")
    dur = args.duration or sc.duration
    solver = args.solver or sc.solver.get('type', 'hqp')
    print(f"{doc.strip().split(chr(10))[0]}\n  scenario {scenario} (bundled), solver {solver}, "
          f"{dur:.1f} s simulated at {1 / sc.dt:.0f} Hz")
    scene = Scene(sc.robot, sc.environment, open_browser=live, record=not live)
    try:
        if live:
            print(f"browser view: {scene.url}")
        cb = viewer_callback(scene, sc.stack, sc.dt, realtime=live, speed=args.speed,
                             frames=shown_frames(sc))
        m = run(sc, solver=args.solver, duration=dur, progress=True, callback=cb, series=bool(args.plot))
        if not live:
            Path(args.record).parent.mkdir(parents=True, exist_ok=True)
            print(f"replay written to {scene.save_html(args.record)} (open it in a browser; works offline)")
        elif sys.stdin.isatty():
            input("run finished: press Enter to close the browser view ")
    finally:
        scene.close()
    if args.plot:
        from wbc.runner.plot import plot_metrics

        print(f"plot written to {plot_metrics(m, args.plot)}")
    _summary(m)
    return 0 if not m["fell"] else 1
