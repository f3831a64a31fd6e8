"""The ``wbc`` command: run, plot, validate, examples, robots, tasks, bench."""

from __future__ import annotations

import argparse
import inspect
import json
import sys
import textwrap
from pathlib import Path

from wbc.cli.exits import dispatch
from wbc.controller.solver_names import SOLVERS
from wbc.sim.backends import SIMULATORS

EPILOG = """examples:
  wbc run talos_balance                                a bundled scenario, live in the browser (URL printed)
  wbc run talos_reach --headless --metrics m.json --plot m.png --record m.html
  wbc run my_scenario.yaml --headless                  your own scenario file
  wbc plot m.json -o again.png                         re-plot a run saved with --series or --plot
  wbc validate talos_step                              exit 0, or 2 with file, key path and expectation
  wbc examples my_scenarios/                           copy the bundled scenarios out, to edit
  wbc robots | wbc tasks | wbc bench --quick

units: SI throughout (m, rad, N, N·m, s); metrics JSON as described in README.md.
exit status: 0 ok, 1 the robot fell or the controller failed, 2 bad input (file, line, key path and
what was expected), 3 an internal error (a bug: wbc --debug COMMAND ... prints its traceback)."""


def _cmd_run(args) -> int:
    from wbc.runner.loop import run
    from wbc.runner.options import RunOptions
    from wbc.scenario.loader import check_mode, load_config

    sc = load_config(args.file)
    check_mode(sc, args.mode)               # a torque-only task in --mode velocity: file, line, key path
    if args.duration is not None:           # the scenario's own `duration:` rule, keyed by the option
        from wbc.errors import ConfigError
        from wbc.scenario.sections import duration_value

        try:
            duration_value(args.duration, sc.dt)
        except ConfigError as exc:
            raise ConfigError(exc.message, key="--duration") from None
    callback, scene = None, None
    if args.record:
        from wbc.viz import Scene, shown_frames, viewer_callback

        scene = Scene(sc.robot, sc.environment, record=True, fps=args.fps, live=False)
        callback = viewer_callback(scene, sc.stack, sc.dt, realtime=False, fps=args.fps,
                                   diagnostics_hz=args.diagnostics_rate, frames=shown_frames(sc))
    want_series = bool(args.plot or args.series)
    if args.blas_threads < 0:
        raise ConfigError(f"{args.blas_threads}: expected a thread count ≥ 1, or 0 to leave it", key="--blas-threads")
    try:
        options = RunOptions(solver=args.solver, backend=args.backend, duration=args.duration, mode=args.mode,
                             simulator=args.sim, joint_dynamics=True if args.joint_dynamics else None,
                             series=want_series, progress=True, callback=callback,
                             blas_threads=args.blas_threads or None)
        if args.headless:
            metrics = run(sc, options)
        else:
            from wbc.cli.live import run_with_view

            metrics = run_with_view(sc, options, host=args.host, port=args.port, fps=args.fps, speed=args.speed,
                                    wait=args.wait, keep=args.keep, mesh_cell=args.mesh_cell,
                                    pixel_ratio=args.pixel_ratio)
    finally:
        if scene is not None:
            print(f"recording written to {scene.save_html(args.record)}")
            scene.close()
    if args.plot:
        from wbc.runner.plot import plot_metrics

        print(f"plot written to {plot_metrics(metrics, args.plot)}")
    series = metrics.get("series") if not args.series else None
    if series is not None:      # plotted but not asked to be kept
        del metrics["series"]
    if args.metrics:
        Path(args.metrics).write_text(json.dumps(metrics, indent=None if args.series else 2) + "\n")
        print(f"metrics written to {args.metrics}")
    else:
        summary = {k: v for k, v in metrics.items() if k != "series"}
        print(json.dumps(summary, indent=2))
    if metrics.get("saturated_cycles"):
        print(f"wbc: torques saturated at the actuator limits in {metrics['saturated_cycles']} control cycles "
              f"(the solver asked up to {metrics['tau_ratio_requested_max']:.2f} × τ_max)", file=sys.stderr)
    for sg in metrics.get("singularities", []):      # once per level: its first near-singular cycle
        where = f" in {', '.join(sg['directions'])}" if sg["directions"] else ""
        joints = f" (joints {', '.join(sg['joints'])})" if sg["joints"] else ""
        count = metrics["singular_cycles"][sg["level"]]
        print(f"wbc: warning: level {sg['level']} ({', '.join(sg['tasks'])}) near-singular{where}{joints} "
              f"from t = {sg['time']:.3f} s: σ_min {sg['sigma_min']:.3g} below the damping threshold, "
              f"its step damped in {count} control cycles", file=sys.stderr)
    stopped = metrics.get("stopped")
    if stopped:
        print(f"wbc: run stopped at t = {stopped['time']:.3f} s by the {stopped['by']}: {stopped['reason']} "
              f"(metrics of the cycles before)", file=sys.stderr)
    return 1 if metrics["fell"] or metrics["solver_failures"] or stopped else 0


def _cmd_plot(args) -> int:
    from wbc.runner.plot import plot_file

    out = args.output or str(Path(args.metrics).with_suffix(".png"))
    print(f"plot written to {plot_file(args.metrics, out, size=(args.width / args.dpi, args.height / args.dpi), dpi=args.dpi)}")
    return 0


def _cmd_validate(args) -> int:
    from wbc.scenario.loader import load_config

    sc = load_config(args.file)
    print(f"{args.file}: ok ({sc.robot.name}, {len(sc.stack)} levels, {sum(1 for _ in sc.stack)} tasks, "
          f"solver {sc.solver.get('type', 'hqp')})")
    return 0


def _cmd_examples(args) -> int:
    from wbc.scenario.examples import SCENARIOS_DIR, available_scenarios, copy_examples

    if args.dest is None:
        print(f"bundled scenarios ({SCENARIOS_DIR}):")
        for name in available_scenarios():
            print(f"  {name}")
        print("run one by name (wbc run talos_balance) or copy them out: wbc examples DIR")
        return 0
    written = copy_examples(args.dest, overwrite=args.force)
    for f in written:
        print(f"wrote {f}")
    skipped = len(available_scenarios()) - len(written)
    if skipped:
        print(f"{skipped} existing file(s) kept (--force overwrites)")
    return 0


def _cmd_robots(args) -> int:
    from wbc.robot.loader import available_robots, load_robot

    if getattr(args, "files", None):         # robot YAMLs of the user's: the full description
        from wbc.cli.robot import describe

        for f in args.files:
            print(describe(load_robot(f)))
        return 0
    for name in available_robots():
        r = load_robot(name)
        print(f"{name}: nq {r.nq}, nv {r.nv}, root {r.root}{' (differential drive)' if r.differential_drive else ''}")
        print(f"  frames:   {', '.join(f'{a} ({f})' for a, f in r.frames.items())}")
        if r.contacts:
            print(f"  contacts: {', '.join(r.contacts)}")
    return 0


#: what each task parameter means, with its unit (shown by `wbc tasks`)
PARAM_HELP: dict = {
    "kp": "proportional gain, 1/s² (ë + kd ė + kp e = 0, eq. 5.17)",
    "kd": "derivative gain, 1/s (None: 2√kp, critically damped)",
    "weight": "weight inside its level, unitless",
    "name": "task name in the stack (None: derived from the frame/contact)",
    "target": "reference (None: the value at the start)",
    ("com", "target"): "CoM position (3,), m (None: the start value)",
    ("frame", "target"): "pose: position (m) and rotation (None: the start pose)",
    ("posture", "target"): "full configuration (nq,), rad or m (None: the robot's default posture)",
    ("contact_wrench", "contact"): "name of the contact task in the stack, e.g. left_foot_contact",
    ("contact_wrench", "target"): "desired wrench (fx fy fz tx ty tz), N and N·m",
    "axes": "controlled CoM axes, e.g. 'xy'",
    "contact": "contact surface name under `contacts:` of the robot YAML",
    "mu": "friction coefficient, unitless (None: the robot's)",
    "fmin": "minimum normal force, N",
    "bilateral": "allow pulling (no unilateral bound)",
    "sliding": "slide along the surface: rows on the normal directions only (hybrid force/motion)",
    ("force", "contact"): "name of the contact task in the stack whose force is tracked, e.g. hand_pad_contact",
    ("force", "target"): "desired force λ_D along the directions, N (N·m along a moment direction)",
    ("force", "directions"): "S_f: one direction or a list, in the contact's force axes (3: point, world; "
                             "6: surface, local); None: the normal",
    ("force", "kp"): "K_P of the measured-force feedback, unitless, in [0, 1)",
    ("force", "ki"): "K_I of the integral action, 1/s (0: none)",
    ("force", "integral_limit"): "anti-windup bound on |K_I ∫e dt|, N",
    ("force", "max_force"): "bound on the commanded force per direction, N (pushing directions: >= 0)",
    ("force", "ramp"): "rise time of the target from 0 (quintic) after the first measurement, s",
    ("force", "source"): "measurement: 'simulator' (the contact force, a force sensor) or 'observer' "
                         "(momentum observer, no sensor)",
    ("force", "observer_gain"): "momentum observer gain K_O, 1/s (time constant 1/K_O)",
    ("force", "tangential"): "force outside S_f: 'free' (lower levels decide) or 'measured' (fed forward)",
    ("force", "motion"): "hybrid partner: the frame task driving S_v (S_fᵀ S_v = 0 is checked)",
    "frame": "frame name or alias (see `wbc robots`)",
    ("collision_avoidance", "influence"): "d_i, m: pairs closer than this get a row",
    ("collision_avoidance", "safety"): "d_s, m (< d_i): the distance never to go below",
    ("collision_avoidance", "max_speed"): "v̄, m/s: the fastest approach stopped before d_s (ω = v̄/(d_i − d_s))",
    ("collision_avoidance", "max_rows"): "rows per cycle (the nearest pairs)",
    ("collision_avoidance", "self_collision"): "monitor the robot's self pairs (ROBOT.collisions.yaml, "
                                               "`wbc robot collisions`)",
    ("collision_avoidance", "obstacles"): "fixed obstacles: [{type: sphere|box|cylinder|capsule|plane, ...}], m",
    ("collision_avoidance", "links"): "robot links kept from the obstacles (None: all)",
    ("collision_avoidance", "environment"): "the scenario's environment shapes are obstacles too",
    "mask": "'pose', 'position', 'orientation' or 6 flags (x y z rx ry rz)",
    "dt": "control period used for the velocity bound, s",
    "horizon": "look-ahead of the position bound, s",
    "max_acceleration": "deceleration available to stop before a limit, rad/s² or m/s²",
    "margin": "distance kept from the position limits, rad or m",
    "recovery": "a joint faster than max_acceleration can stop: 'one_period' (back under that curve in one "
                "period) or 'stop' (the constant deceleration v²/(2d) that stops it at the limit)",
    "joints": "joint names (None: every non-root joint)",
    "scale": "fraction (0, 1] of the URDF torque limits",
    ("null_space_impedance", "frame"): "frame of a pose task above (protected: the impedance acts in its null space)",
    ("null_space_impedance", "protect"): "more protected frames or 'com', each held by a task above; the contacts "
                                         "are always protected",
    ("null_space_impedance", "zeta"): "damping ratio of every null-space mode (instead of B_nu)",
    ("null_space_impedance", "target"): "posture q_d (nq,) of the null-space spring, rad (None: the start)",
    ("singularity_avoidance", "frame"): "frame whose manipulability √det(J Jᵀ) over its joints is kept (see `wbc robots`), "
                                        "or 'com': the CoM's over the actuated joints (mask 'position')",
    ("singularity_avoidance", "threshold"): "w_min: the task acts below it, m^p (p the mask's position rows: m³ "
                                            "for 'position'), > 0",
    ("singularity_avoidance", "mask"): "'position', 'orientation' or 'pose': the Jacobian rows measured",
    ("singularity_avoidance", "limit_penalty"): "k of the joint-limit penalty, unitless (0: Yoshikawa's w alone)",
    "k_q": "null-space joint stiffness, N·m/rad (scalar or one per joint)",
    "B_nu": "null-space damping, N·m·s/rad (scalar or matrix)",
}


def _cmd_tasks(args) -> int:
    from wbc.options import flat_parameters
    from wbc.tasks import TASK_TYPES

    for kind, cls in sorted(TASK_TYPES.items()):
        doc = " ".join((inspect.getdoc(cls) or "").split("\n\n")[0].split())
        print(f"{kind}: {doc}")
        for p in flat_parameters(cls.__init__, cls.options_record).values():
            default = " (required)" if p.default is inspect.Parameter.empty else f" = {p.default!r}"
            about = PARAM_HELP.get((kind, p.name), PARAM_HELP.get(p.name, ""))
            print(f"    {p.name + default:26s}" + (f" {about}" if about else ""))
    return 0


def _cmd_trajectories(args) -> int:
    """Every trajectory key (wbc.trajectories.position.KEYS, wbc.trajectories.rotation.KEYS) with its unit."""
    from wbc.trajectories.position import KEYS
    from wbc.trajectories.rotation import KEYS as ROTATION_KEYS

    for title, keys in (("trajectory: (a com or frame task's, or an `events: add`'s)", KEYS),
                        ("rotation: (inside a frame task's trajectory)", ROTATION_KEYS)):
        print(title)
        for kind, params in keys.items():
            print(f"  {'type: ' + kind if kind[0] != '(' else kind}")
            for name, about in params.items():
                print(f"    {name:12s} {about}")
    return 0


class _Help(argparse.HelpFormatter):
    """Wraps prose paragraphs, keeps indented lines (examples) as written."""

    def __init__(self, prog):
        super().__init__(prog, max_help_position=30, width=100)

    def _fill_text(self, text, width, indent):
        return "\n".join(indent + line if not line or line.startswith("  ") else
                         textwrap.fill(line, width, initial_indent=indent, subsequent_indent=indent)
                         for line in text.split("\n"))


def build_parser() -> argparse.ArgumentParser:
    """The ``wbc`` argument parser (every option with its unit and default)."""
    from wbc.viz.live import LIVE_MESH_CELL

    parser = argparse.ArgumentParser(
        prog="wbc", formatter_class=_Help, epilog=EPILOG,
        description="Whole-body multi-priority control on Pinocchio: run scenario YAMLs in closed loop "
                    "with a simulator, watch them in the browser (Meshcat), plot and benchmark them.")
    parser.add_argument("--debug", action="store_true",
                        help="on an error, also print the Python traceback (for a bug report: "
                             "wbc --debug run ...)")
    sub = parser.add_subparsers(dest="cmd", required=True, metavar="COMMAND")

    r = sub.add_parser(
        "run", formatter_class=_Help, help="simulate a scenario YAML; browser view, metrics, plots, recordings",
        description="Simulate a scenario (a YAML file or a bundled scenario's name): the controller drives a "
                    "simulation at the scenario's control rate. Without --headless a Meshcat server starts, its page "
                    "on 127.0.0.1 only (--host to serve it elsewhere), its URL is printed and the run plays in real "
                    "time with the priority diagnostics (per level: residual, rank and σ_min of the projected "
                    "Jacobian, sacrificed tasks, active constraints) drawn top left. Prints the metrics JSON (or "
                    "writes it with --metrics). Exit status: 0, 1 if the robot fell or the solver failed, 2 on a "
                    "bad scenario.",
        epilog="examples:\n  wbc run talos_push --headless --solver projection --duration 3\n"
               "  wbc run talos_reach --headless --plot reach.png --record reach.html\n"
               "  wbc run my_scenario.yaml --headless")
    r.add_argument("file", help="scenario YAML, or the name of a bundled scenario (see `wbc examples`)")
    r.add_argument("--headless", action="store_true",
                   help="no browser view: run as fast as possible and print progress (simulated time, "
                        "real-time factor, solver failures)")
    r.add_argument("--duration", type=float, metavar="S",
                   help="simulated duration in s (default: the scenario's `duration`)")
    r.add_argument("--solver", choices=list(SOLVERS),
                   help="priority solver (default: the scenario's `solver.type`, else hqp)")
    r.add_argument("--mode", choices=["torque", "velocity"],
                   help="control mode: torque (x = (q̈, f), torques) or velocity (x = q̇, position-controlled "
                        "actuators; wbc.controller.velocity); default: the scenario's `mode`, else torque")
    r.add_argument("--sim", choices=list(SIMULATORS),
                   help="physics: pinocchio (wbc's own, rigid contacts) or mujoco (MuJoCo's soft contacts, "
                        "pip install 'wbc[mujoco]'); default: the scenario's `simulator`, else pinocchio")
    r.add_argument("--joint-dynamics", action="store_true",
                   help="the URDF's joint damping and friction act in the simulator (default: the scenario's "
                        "`joint_dynamics`, else off); the controller compensates them if the robot YAML's "
                        "`compensate:` says so")
    r.add_argument("--backend", metavar="NAME",
                   help="QP back-end: daqp, proxqp, or any qpsolvers name (default: the scenario's, else daqp)")
    r.add_argument("--metrics", metavar="FILE.json",
                   help="write the metrics JSON here (SI units; default: print it)")
    r.add_argument("--series", action="store_true",
                   help="record the time series (task errors per level, level residual/rank/σ_min, contact "
                        "normal forces and friction margins, torque/limit ratios, support margin) and keep them "
                        "under \"series\" in the metrics JSON, for `wbc plot` (default: off; a few MB for 10 s)")
    r.add_argument("--plot", metavar="FILE.png",
                   help="plot the run (task errors per level, contact forces and friction margins, torques "
                        "against limits) into this PNG, 1200×800 px (implies recording the series)")
    r.add_argument("--record", metavar="FILE.html",
                   help="write a self-contained HTML replay (plays offline: the viewer's JavaScript is embedded), "
                        "with the diagnostics panel following the replay")
    r.add_argument("--host", default="127.0.0.1", metavar="ADDR",
                   help="address the browser view's page listens on (default 127.0.0.1: this machine only; "
                        "0.0.0.0: every interface, e.g. to watch and act from another machine)")
    r.add_argument("--port", type=int, default=8080, metavar="N",
                   help="the page's port (default 8080, or the next free one)")
    r.add_argument("--wait", action="store_true",
                   help="start the run once a browser has connected to the page")
    r.add_argument("--keep", action="store_true",
                   help="after the run, keep serving the page with the last state (until Enter or Ctrl-C)")
    r.add_argument("--speed", type=float, default=1.0, metavar="X",
                   help="live playback speed, 1 = real time, 0.5 = half speed (default 1.0; ignored with --headless)")
    r.add_argument("--fps", type=float, default=30.0, metavar="HZ",
                   help="frames drawn per second, live (wall time, by a drawing thread) and in recordings "
                        "(simulated time) (default 30)")
    r.add_argument("--mesh-cell", type=float, default=LIVE_MESH_CELL, metavar="M",
                   help=f"the live page's robot meshes thinned on a grid of M metres (default {LIVE_MESH_CELL:g}; "
                        "0: the full meshes; a browser rendering in software draws fewer triangles faster)")
    r.add_argument("--pixel-ratio", type=float, default=None, metavar="R",
                   help="the live page's canvas pixels per CSS pixel (default: the browser's; e.g. 0.5 for a "
                        "browser rendering in software)")
    r.add_argument("--diagnostics-rate", type=float, default=10.0, metavar="HZ",
                   help="priority-diagnostics updates per simulated second in the view (default 10; 0: off)")
    r.add_argument("--blas-threads", type=int, default=1, metavar="N",
                   help="OpenBLAS threads during the control loop (default 1: the cascade's matrices are too "
                        "small for threads to pay; 0: leave the count as the environment set it)")
    r.set_defaults(fn=_cmd_run)

    p = sub.add_parser(
        "plot", formatter_class=_Help, help="plot a metrics JSON saved with `wbc run --series` (or --plot)",
        description="Plot a run's time series: one panel per priority level (task error norms in m or rad; "
                    "level 0 its residual ‖Ax − b‖, log scale; titles give rank and min σ of J̄_k), contact "
                    "normal forces (N, m g for reference), friction margins μ F_n − ‖F_t‖ (N, < 0 means "
                    "sliding), and joint torques against their limits (|τ_i|/τ_max,i: the worst per cycle and "
                    "the joints that came closest). Exit 2 if the file has no series.",
        epilog="example:\n  wbc run talos_step --headless --series --metrics step.json\n"
               "  wbc plot step.json -o step.png")
    p.add_argument("metrics", metavar="METRICS.json", help="metrics JSON written by `wbc run --series --metrics`")
    p.add_argument("-o", "--output", metavar="FILE.png",
                   help="output PNG (default: METRICS with the suffix .png)")
    p.add_argument("--width", type=int, default=1200, metavar="PX", help="image width in pixels (default 1200)")
    p.add_argument("--height", type=int, default=800, metavar="PX", help="image height in pixels (default 800)")
    p.add_argument("--dpi", type=int, default=100, help="dots per inch: sets text size relative to the image "
                   "(default 100)")
    p.set_defaults(fn=_cmd_plot)

    v = sub.add_parser("validate", formatter_class=_Help, help="check a scenario YAML; exit 0, or 2 with the error",
                       description="Load and check a scenario YAML without running it: robot, frames, task "
                                   "parameters, trajectories, events. Exit 0 and a one-line summary, or exit 2 "
                                   "with the file, the key path and what was expected.")
    v.add_argument("file", help="scenario YAML, or a bundled scenario's name")
    v.set_defaults(fn=_cmd_validate)
    e = sub.add_parser("examples", formatter_class=_Help, help="list the bundled scenarios, or copy them into DIR",
                       description="Without DIR: list the scenarios shipped with wbc (run them by name: "
                                   "`wbc run talos_balance`). With DIR: copy their YAMLs there to edit.")
    e.add_argument("dest", nargs="?", metavar="DIR", help="folder to copy the scenario YAMLs into (created)")
    e.add_argument("--force", action="store_true", help="overwrite files that exist in DIR")
    e.set_defaults(fn=_cmd_examples)
    rb = sub.add_parser("robots", formatter_class=_Help, help="list the bundled robots and their named frames",
                   description="List the bundled robots (wbc/data/robots/*.yaml): nq, nv, root joint, named frames "
                               "(alias and URDF frame) and contact surfaces. With FILE.yaml (or a bundled name): "
                               "that robot's frames, contacts, limits, mass, gains and the static-torque margin at "
                               "its default posture, with its warnings.")
    rb.add_argument("files", nargs="*", metavar="FILE.yaml", help="robot YAMLs (or bundled names) to describe")
    rb.set_defaults(fn=_cmd_robots)
    sub.add_parser("tasks", formatter_class=_Help, help="list task types with their parameters and defaults",
                   description="List the task types a scenario's `stack` accepts, with their parameters "
                               "and default values (gains in 1/s² and 1/s, weights unitless, forces in N)."
                   ).set_defaults(fn=_cmd_tasks)
    sub.add_parser("trajectories", formatter_class=_Help, help="list trajectory types and keys, with units",
                   description="List the keys of a task's `trajectory:` (constant, sinusoid, circle, waypoints, "
                               "spline) and of its `rotation:` (frame tasks), with units (m, s, Hz, rad)."
                   ).set_defaults(fn=_cmd_trajectories)
    from wbc.cli.bench import add_parser as add_bench_parser

    add_bench_parser(sub)
    from wbc.cli.sweep import add_parser as add_sweep_parser

    add_sweep_parser(sub)
    from wbc.cli.robot import add_parser as add_robot_parser

    add_robot_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one `wbc` command; returns its exit status (:data:`~wbc.cli.exits.EXIT_OK` ...
    :data:`~wbc.cli.exits.EXIT_INTERNAL`, see :func:`~wbc.cli.exits.dispatch`)."""
    return dispatch(build_parser().parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
