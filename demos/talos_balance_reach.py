"""Talos balances on its two feet while both hands reach targets 30 cm away.

Closed loop: the wbc controller (strict HQP) drives a pinocchio simulation with
rigid frictional foot contacts at 1 kHz. Prints the run's metrics. With --viz (or
a display) it plays live in the browser (Meshcat, 127.0.0.1); otherwise it runs
headless and writes a self-contained HTML replay under recordings/.

    python demos/talos_balance_reach.py [--viz] [--solver hqp|projection|weighted] [--duration S]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--solver", default="hqp", choices=["hqp", "projection", "weighted"])
    parser.add_argument("--duration", type=float, default=4.0)
    parser.add_argument("--viz", action="store_true", help="play live in the browser (Meshcat)")
    parser.add_argument("--record", default=str(ROOT / "recordings" / "talos_balance_reach.html"),
                        help="where the headless run writes its HTML replay")
    args = parser.parse_args()

    import os

    from wbc.runner import run
    from wbc.scenario import load_config
    from wbc.viz import Scene, viewer_callback

    live = args.viz or bool(os.environ.get("DISPLAY"))
    sc = load_config(ROOT / "tasks" / "talos_reach.yaml")
    print(f"Talos balance-and-reach, solver {args.solver}, {args.duration:.1f} s simulated at 1 kHz")
    scene = Scene(sc.robot, sc.environment, open_browser=live, record=not live)
    if live:
        print(f"browser view: {scene.url}")
    cb = viewer_callback(scene, sc.stack, sc.dt, realtime=live)
    m = run(sc, solver=args.solver, duration=args.duration, progress=True, callback=cb)
    if not live:
        Path(args.record).parent.mkdir(parents=True, exist_ok=True)
        print(f"replay written to {scene.save_html(args.record)} (open it in a browser; works offline)")
    scene.close()
    print(f"  fell: {m['fell']}   solver failures: {m['solver_failures']}   "
          f"real-time factor: {m['real_time_factor']:.2f}")
    for name, s in m["tasks"].items():
        print(f"  {name:12s} error  rms {s['rms'] * 1e3:8.2f}  max {s['max'] * 1e3:8.2f}  final {s['final'] * 1e3:8.2f}  (mm or mrad)")
    for name, c in m["contacts"].items():
        print(f"  {name:12s} slip {c['slip'] * 1e3:.3f} mm   lifted: {c['lifted']}")
    print(f"  CoM margin inside the support polygon (min): {m['support_margin_min'] * 100:.1f} cm")
    print(f"  limit violations (cycles): {m['violations']}")
    print(f"  control cycle: median {m['cycle_time']['median'] * 1e3:.2f} ms, p99 {m['cycle_time']['p99'] * 1e3:.2f} ms")
    return 0 if not m["fell"] else 1


if __name__ == "__main__":
    sys.exit(main())
