"""Shared body of the scenario demos: run one ``wbc/data/scenarios/*.yaml`` in the browser view.

Live (the viser page on 127.0.0.1, URL printed, real time: drag the targets, change gains,
pause, push; see docs/viewer.md) with ``--viz`` or when a display is available; otherwise
headless, writing a self-contained HTML replay (Meshcat, plays offline) to
``recordings/<name>.html`` and printing its path. ``--plot out.png`` adds the run's plots. Prints the metrics.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


#: how the summary shows a task error of each unit: (factor, shown unit)
SHOWN_UNITS = {"m": (1e3, "mm"), "rad": (1e3, "mrad"), "N": (1.0, "N"), "N·m": (1.0, "N·m")}


def _summary(m: dict) -> None:
    print(f"  fell: {m['fell']}   solver failures: {m['solver_failures']}   "
          f"real-time factor: {m['real_time_factor']:.2f}")
    for name, s in m["tasks"].items():
        for label, part in (s.get("parts") or {s.get("unit", ""): s}).items():
            scale, unit = SHOWN_UNITS.get(label, (1.0, label))
            print(f"  {name:14s} error  rms {part['rms'] * scale:9.3f}  max {part['max'] * scale:9.3f}  "
                  f"final {part['final'] * scale:9.3f}  ({unit})")
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
                        help="play live in the browser (viser on 127.0.0.1) even without a display")
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
    if live:
        from wbc.cli.live import run_with_view
        from wbc.runner.options import RunOptions

        m = run_with_view(sc, RunOptions(solver=args.solver, duration=dur, progress=True, series=bool(args.plot)),
                          speed=args.speed, keep=sys.stdin.isatty())
    else:
        scene = Scene(sc.robot, sc.environment, record=True)
        try:
            cb = viewer_callback(scene, sc.stack, sc.dt, realtime=False, frames=shown_frames(sc))
            m = run(sc, solver=args.solver, duration=dur, progress=True, callback=cb, series=bool(args.plot))
            Path(args.record).parent.mkdir(parents=True, exist_ok=True)
            print(f"replay written to {scene.save_html(args.record)} (open it in a browser; works offline)")
        finally:
            scene.close()
    if args.plot:
        from wbc.runner.plot import plot_metrics

        print(f"plot written to {plot_metrics(m, args.plot)}")
    _summary(m)
    return 0 if not m["fell"] else 1
