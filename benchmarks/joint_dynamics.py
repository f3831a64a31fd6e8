"""Joint damping and friction (the URDF's) in both simulators, compensated by the controller or not.

    nice python benchmarks/joint_dynamics.py [--scenarios talos_balance tiago_reach] [--duration S]

For each scenario and simulator, four closed-loop runs of the bundled scenario: ``off`` (no
joint dynamics, the bundled result), ``on`` (``joint_dynamics: true``: the URDF's damping and
dry friction act in the simulator, the controller ignores them), ``on + comp D`` (the same,
the robot YAML with ``compensate: {damping: true}``: the controller's h includes D q̇) and
``on + comp D+F`` (``compensate: {damping: true, friction: true}``: h includes
D q̇ + F tanh(q̇ / 0.01)). Each variant is the bundled YAML with that one key added,
written to a temporary folder and loaded as any scenario. Prints a Markdown table (each task's
error RMS, m or rad; the worst foot slip, mm; saturated cycles; fell) and writes it to
``benchmarks/joint_dynamics.md``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent


def variant(tmp: Path, scenario: str, joint_dynamics: bool, compensate: str = "") -> Path:
    """The bundled ``scenario`` with ``joint_dynamics`` and its robot's ``compensate:`` set
    (``compensate``: "" none, "D" damping, "DF" damping and friction)."""
    from wbc.robot.loader import robot_yaml_path
    from wbc.scenario.examples import scenario_path

    sc = yaml.safe_load(scenario_path(scenario).read_text())
    robot = yaml.safe_load(robot_yaml_path(sc["robot"]).read_text())
    if compensate:
        robot["compensate"] = {"damping": "D" in compensate, "friction": "F" in compensate}
    rpath = tmp / f"{robot['name']}_{compensate or 'plain'}.yaml"
    rpath.write_text(yaml.safe_dump(robot))
    sc["robot"] = str(rpath)
    sc["joint_dynamics"] = joint_dynamics
    path = tmp / f"{scenario}_{int(joint_dynamics)}{compensate}.yaml"
    path.write_text(yaml.safe_dump(sc))
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=["talos_balance", "talos_reach", "tiago_reach"])
    ap.add_argument("--simulators", nargs="+", default=["pinocchio", "mujoco"])
    ap.add_argument("--duration", type=float, default=None, help="s (default: the scenario's)")
    ap.add_argument("--output", default=str(HERE / "joint_dynamics.md"))
    args = ap.parse_args(argv)
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    rows = ["| scenario | simulator | joint dynamics | task error RMS | max slip (mm) | saturated | fell |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenarios:
            for sim in args.simulators:
                for label, jd, comp in (("off", False, ""), ("on", True, ""), ("on + comp D", True, "D"),
                                        ("on + comp D+F", True, "DF")):
                    m = run(load_config(variant(Path(tmp), name, jd, comp)), simulator=sim, duration=args.duration)
                    err = ", ".join(f"{t} {v['rms']:.4g}" for t, v in m["tasks"].items())
                    slip = max((c["slip"] for c in m["contacts"].values()), default=0.0)
                    rows.append(f"| {name} | {sim} | {label} | {err} | {1e3 * slip:.3f} | "
                                f"{m['saturated_cycles']} | {m['fell']} |")
                    print(rows[-1], flush=True)
    text = "\n".join([f"# Joint damping and friction (`python benchmarks/joint_dynamics.py`"
                      f"{' --duration ' + str(args.duration) if args.duration else ''})", "",
                      "Task error RMS in m (CoM, positions) or rad (orientations, posture); "
                      "`comp D`: the robot YAML's `compensate: {damping: true}`; `comp D+F`: "
                      "`compensate: {damping: true, friction: true}` (friction_velocity 0.01 rad/s).", ""]
                     + rows) + "\n"
    Path(args.output).write_text(text)
    print(f"written to {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
