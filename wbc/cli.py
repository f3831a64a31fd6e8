"""The ``wbc`` command: run, validate, robots, tasks."""

from __future__ import annotations

import argparse
import inspect
import json
import sys
from pathlib import Path

from .errors import WbcError


def _cmd_run(args) -> int:
    from .runner import run
    from .scenario import load_config

    sc = load_config(args.file)
    callback, scene = None, None
    if not args.headless or args.record:
        from .viz import Scene, viewer_callback

        scene = Scene(sc.robot, sc.environment, record=bool(args.record))
        if not args.headless:
            print(f"wbc: browser view at {scene.url}  (Ctrl-C to stop)", flush=True)
        callback = viewer_callback(scene, sc.stack, sc.dt, realtime=not args.headless, speed=args.speed)
    try:
        metrics = run(sc, solver=args.solver, backend=args.backend, duration=args.duration,
                      progress=True, callback=callback)
    finally:
        if scene is not None:
            if args.record:
                print(f"recording written to {scene.save_html(args.record)}")
            scene.close()
    text = json.dumps(metrics, indent=2)
    if args.metrics:
        Path(args.metrics).write_text(text + "\n")
        print(f"metrics written to {args.metrics}")
    else:
        print(text)
    return 1 if metrics["fell"] or metrics["solver_failures"] else 0


def _cmd_validate(args) -> int:
    from .scenario import load_config

    sc = load_config(args.file)
    print(f"{args.file}: ok ({sc.robot.name}, {len(sc.stack)} levels, {sum(1 for _ in sc.stack)} tasks, "
          f"solver {sc.solver.get('type', 'hqp')})")
    return 0


def _cmd_robots(args) -> int:
    from .robots import available_robots, load_robot

    for name in available_robots():
        r = load_robot(name)
        print(f"{name}: nq {r.nq}, nv {r.nv}, root {r.root}{' (differential drive)' if r.differential_drive else ''}")
        print(f"  frames:   {', '.join(f'{a} ({f})' for a, f in r.frames.items())}")
        if r.contacts:
            print(f"  contacts: {', '.join(r.contacts)}")
    return 0


def _cmd_tasks(args) -> int:
    from .tasks import TASK_TYPES

    for kind, cls in sorted(TASK_TYPES.items()):
        doc = (inspect.getdoc(cls) or "").split("\n")[0]
        print(f"{kind}: {doc}")
        for p in list(inspect.signature(cls.__init__).parameters.values())[1:]:
            default = "" if p.default is inspect.Parameter.empty else f" = {p.default!r}"
            print(f"    {p.name}{default}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="wbc", description="Whole-body multi-priority control on Pinocchio.")
    sub = parser.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="simulate a scenario YAML and report its metrics")
    r.add_argument("file", help="scenario YAML (tasks/*.yaml)")
    r.add_argument("--headless", action="store_true", help="no browser view")
    r.add_argument("--duration", type=float, help="override the scenario duration (s)")
    r.add_argument("--solver", choices=["hqp", "projection", "weighted"], help="override the solver")
    r.add_argument("--backend", help="QP back-end: daqp, proxqp, or any qpsolvers name")
    r.add_argument("--metrics", help="write the metrics JSON here (SI units)")
    r.add_argument("--record", help="write a self-contained HTML replay of the run here")
    r.add_argument("--speed", type=float, default=1.0, help="playback speed in the browser (1 = real time)")
    r.set_defaults(fn=_cmd_run)
    v = sub.add_parser("validate", help="check a scenario YAML; exit 0, or 2 with the error")
    v.add_argument("file")
    v.set_defaults(fn=_cmd_validate)
    sub.add_parser("robots", help="list the bundled robots and their named frames").set_defaults(fn=_cmd_robots)
    sub.add_parser("tasks", help="list task types with their parameters and defaults").set_defaults(fn=_cmd_tasks)
    from .bench import add_parser as add_bench_parser

    add_bench_parser(sub)
    args = parser.parse_args(argv)
    try:
        return args.fn(args)
    except WbcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
