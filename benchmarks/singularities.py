"""Singularities: the issue-27 figures, both simulators, the three solvers.

    PYTHONPATH=. python benchmarks/singularities.py [OUT.md [CASE ...]]

(CASE: panda, wrist, crouch, g1, go2; default all. Durations: the Panda's 4.5 s, 1.5 s for the G1 and the
go2, the standing and the bending being over by then.)

Cases: panda_reach_boundary (the hand out to 20 cm beyond its reach and back),
panda_wrist_singularity (the hand's pose through that of a configuration with aligned wrist and
shoulder axes, rank 5, and back), g1_straight_legs
(the G1 at its zero configuration, straight legs, the singularity_avoidance task above the
posture) and the same stack on the G1 with bent knees (g1.yaml's default posture: the bent
run of the 10× criterion), go2 from `wbc robot init` at its default posture (written to a temporary
directory from the bundled URDF: the zero configuration but for the calves, whose range excludes
0, 10 % of their range inside their upper limit) and the bundled go2 (bent legs); go2_straight_crouch (the go2 with
its legs as straight as its knees allow stands, then crouches 8 cm) and the same scenario from the
bundled go2's bent stance. Per run: fell, cycles over a
joint position/velocity limit or the torque limit, saturated and relaxed cycles, the worst
|τ|/τ_max asked, max |q̈| (rad/s², m/s²), the cycles whose solution (status ok or saturated)
planned a contact force outside its friction cone or with a negative normal force, and the
near-singular cycles per level.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import yaml


def standing(name: str, robot) -> str:
    """The bundled go2_stand scenario as YAML text, named ``name``, with ``robot`` (a name or a
    YAML path), standing still for 2 s (its CoM target held where it starts, no sway)."""
    doc = yaml.safe_load(Path("wbc/data/scenarios/go2_stand.yaml").read_text())
    doc.update(name=name, robot=str(robot), duration=2.0, description="The Go2 standing still.")
    doc["stack"][1] = [{"type": "com"}]
    return yaml.safe_dump(doc)


def _outside_cone(sol, cones: dict) -> bool:
    """Some planned force is outside its contact's own cone (friction pyramid with the
    contact's μ, the surface's when the task gives none; CoP rectangle; normal-force
    bounds): f − f₀ not a non-negative combination of the cone's generators V (NNLS
    residual above 1e-6 (1 + |f|) N)."""
    from scipy.optimize import nnls

    for name, f in sol.forces.items():
        f0, V = cones[name]()
        _, res = nnls(V, f - f0)
        if res > 1e-6 * (1.0 + float(np.linalg.norm(f))):
            return True
    return False


def one(path, solver: str, sim: str, duration: float | None = None) -> dict:
    from wbc.runner.loop import ScenarioRun
    from wbc.scenario.loader import load_config

    sc = load_config(path)
    r = ScenarioRun(sc, solver=solver, simulator=sim, progress=False, duration=duration)
    cones = {t.name: t.generators for t in r.stack if t.kind == "contact"}
    qdd_max, bad_cone = 0.0, 0
    for k in range(r.n):
        ok = r.cycle(k)
        sol = r.last_sol
        if sol is not None and sol.ok:
            qdd_max = max(qdd_max, float(np.abs(sol.qdd).max()))
            if sol.status in ("ok", "saturated") and cones and _outside_cone(sol, cones):
                bad_cone += 1
        if not ok:
            break
    m = r.metrics()
    v = m["violations"]
    return {"fell": m["fell"] or bool(m["stopped"]), "q": v["joint_position"], "v": v["joint_velocity"],
            "tau": v["torque"], "sat": m["saturated_cycles"], "rel": m["relaxed_cycles"],
            "ask": m["tau_ratio_requested_max"], "qdd": qdd_max, "cone": bad_cone,
            "singular": m["singular_cycles"], "t": m["duration"]}


def main(out: str | None, which: list[str]) -> None:
    warnings.simplefilter("ignore")
    tmp = Path(tempfile.mkdtemp())
    from wbc.robot.loader import load_robot

    urdf = load_robot("go2").urdf_path
    subprocess.run([sys.executable, "-m", "wbc.cli", "robot", "init", str(urdf), "-o", str(tmp / "go2_init.yaml")],
                   check=True, capture_output=True)
    (tmp / "go2_zero.yaml").write_text(standing("go2_zero", tmp / "go2_init.yaml"))
    (tmp / "go2_bent.yaml").write_text(standing("go2_bent", "go2"))
    bent_g1 = (Path("wbc/data/scenarios/g1_straight_legs.yaml").read_text().replace("robot: g1_straight", "robot: g1")
               .replace("frame: left_ankle,", "frame: left_ankle_pitch_link,")
               .replace("frame: right_ankle,", "frame: right_ankle_pitch_link,"))
    (tmp / "g1_bent.yaml").write_text(bent_g1.replace("name: g1_straight_legs", "name: g1_bent"))
    crouch = Path("wbc/data/scenarios/go2_straight_crouch.yaml").read_text()
    (tmp / "go2_bent_crouch.yaml").write_text(crouch.replace("robot: go2_straight", "robot: go2")
                                              .replace("name: go2_straight_crouch", "name: go2_bent_crouch"))
    cases = [("panda", "panda_reach_boundary", "panda_reach_boundary", None),
             ("wrist", "panda_wrist_singularity", "panda_wrist_singularity", None),
             ("crouch", "go2_straight_crouch", "go2_straight_crouch", None),
             ("crouch", "go2 bent, same crouch", tmp / "go2_bent_crouch.yaml", None),
             ("g1", "g1_straight_legs", "g1_straight_legs", 1.5),
             ("g1", "g1 bent (same stack)", tmp / "g1_bent.yaml", 1.5),
             ("go2", "go2 init (zero, calves in range)", tmp / "go2_zero.yaml", 1.5),
             ("go2", "go2 bundled, bent", tmp / "go2_bent.yaml", 1.5)]
    lines = ["| case | sim | solver | fell | over q / q̇ / τ limit (cycles) | saturated | relaxed | τ asked / τ_max "
             "| max abs q̈ | planned force outside cone (ok/saturated cycles) | near-singular cycles per level |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for group, label, path, duration in cases:
        if which and group not in which:
            continue
        for sim in ("pinocchio", "mujoco"):
            for solver in ("hqp", "projection", "weighted"):
                r = one(path, solver, sim, duration)
                fell = f"yes ({r['t']:.2f} s)" if r["fell"] else "no"
                lines.append(f"| {label} | {sim} | {solver} | {fell} | {r['q']} / {r['v']} / {r['tau']} | {r['sat']} "
                             f"| {r['rel']} | {r['ask']:.3g} | {r['qdd']:.3g} | {r['cone']} | {r['singular']} |")
                print(lines[-1], flush=True)
    if out:
        Path(out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None, sys.argv[2:])
