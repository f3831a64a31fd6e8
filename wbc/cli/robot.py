"""``wbc robot init URDF`` (a starting robot YAML guessed from a URDF) and
``wbc robots FILE.yaml`` (a description of a user's robot).

What ``init`` guesses, and prints when it cannot decide:

- root: ``fixed`` if the URDF's root link is ``world`` (or joined to it by a fixed joint);
  ``planar`` (actuated) when the tree has wheel-like joints (name containing ``wheel`` or
  ``caster``; they are then locked) or a ``base_footprint`` root with no legs; else
  ``free_flyer``;
- frames: one alias per end link of the kinematic tree (a link with no child joint that
  moves), named after the link; ``base`` for the root link;
- feet by name (``foot``, ``sole``, ``ankle``, ``toe``) among the end links and their
  parents. A foot whose collision is a box: a surface contact, the sole rectangle the
  box's bottom face (an offset frame at its centre, half sizes in m); a foot with
  collision spheres: their bounding rectangle at the spheres' bottom if more than two,
  a point contact with the sphere's radius if one; otherwise a point contact with radius 0
  (to be measured: the line says so);
- hands by name (``hand``, ``gripper``, ``tool``, ``palm``, ``wrist``, ``ee``);
- default posture: the SRDF's first ``group_state`` (by name) if ``--srdf`` is given; else
  the zero configuration, but for the joints whose range excludes 0 (each put 1 % of its range
  inside its nearer limit: a start beyond a limit is a state the robot cannot be in).
"""

from __future__ import annotations

import argparse
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

FOOT_WORDS = ("foot", "sole", "ankle_roll", "toe")
HAND_WORDS = ("hand", "gripper", "tool", "palm", "ee_link", "end_effector")
WHEEL_WORDS = ("wheel", "caster")
SENSOR_WORDS = ("optical", "camera", "cam_", "imu", "laser", "led", "accelerometer", "rotor", "gazebo", "radar",
                "lidar", "d435", "mid360", "logo", "contour", "wheel", "caster", "stereo", "kinect", "sensor")


def _floats(s: str | None, n: int = 3) -> np.ndarray:
    return np.array([float(x) for x in s.split()]) if s else np.zeros(n)


def _collisions(link: ET.Element) -> list[tuple[str, np.ndarray, np.ndarray, dict]]:
    """(kind, xyz, rpy, params) of a link's collision geometries."""
    out = []
    for c in link.findall("collision"):
        o = c.find("origin")
        xyz = _floats(o.get("xyz") if o is not None else None)
        rpy = _floats(o.get("rpy") if o is not None else None)
        g = c.find("geometry")
        if g is None or len(g) == 0:
            continue
        shape = g[0]
        out.append((shape.tag, xyz, rpy, dict(shape.attrib)))
    return out


def _stl_lowest(filename: str, mesh_dir: Path) -> float | None:
    """The lowest z (m, mesh frame) of a binary STL named ``package://<pkg>/<rel>`` or by path
    (looked up under ``mesh_dir``, the folder that holds the URDF's packages); None if unread."""
    import struct

    rel = filename.split("://", 1)[-1]
    for cand in (mesh_dir / rel, Path(rel)):
        if cand.is_file() and cand.suffix.lower() == ".stl":
            b = cand.read_bytes()
            if b[:5] == b"solid":
                return None
            n = struct.unpack("<I", b[80:84])[0]
            rec = np.frombuffer(b[84:84 + 50 * n], dtype=np.dtype([("n", "<3f4"), ("v", "<9f4"), ("a", "<u2")]))
            return float(rec["v"].reshape(-1, 3)[:, 2].min())
    return None


def _contact_from_collisions(name: str, link: str, cols, notes: list[str],
                             mesh_dir: Path | None = None) -> tuple[dict | None, dict]:
    """(offset frame spec or None, contact spec) for a foot link (module docstring)."""
    boxes = [c for c in cols if c[0] == "box" and np.allclose(c[2], 0)]
    spheres = [c for c in cols if c[0] == "sphere"]
    if boxes:
        _, xyz, _, p = boxes[0]
        size = _floats(p["size"])
        frame = {"link": link, "xyz": [round(float(xyz[0]), 4), round(float(xyz[1]), 4),
                                       round(float(xyz[2] - size[2] / 2), 4)]}
        return frame, {"kind": "surface", "half_length": round(float(size[0] / 2), 4),
                       "half_width": round(float(size[1] / 2), 4), "mu": 0.7}
    if len(spheres) > 2:
        c = np.array([s[1] for s in spheres])
        r = max(float(s[3]["radius"]) for s in spheres)
        lo, hi = c.min(axis=0) - r, c.max(axis=0) + r
        frame = {"link": link, "xyz": [round(float((lo[0] + hi[0]) / 2), 4), round(float((lo[1] + hi[1]) / 2), 4),
                                       round(float(c[:, 2].min() - r), 4)]}
        return frame, {"kind": "surface", "half_length": round(float((hi[0] - lo[0]) / 2), 4),
                       "half_width": round(float((hi[1] - lo[1]) / 2), 4), "mu": 0.7}
    if len(spheres) == 1:
        _, xyz, _, p = spheres[0]
        spec = {"kind": "point", "radius": round(float(p["radius"]), 4), "mu": 0.7}
        if np.any(np.abs(xyz) > 1e-9):
            spec["offset"] = [round(float(v), 4) for v in xyz]
        return None, spec
    meshes = [c for c in cols if c[0] == "mesh" and np.allclose(c[2], 0)]
    if len(meshes) == 1 and mesh_dir is not None:
        z = _stl_lowest(meshes[0][3].get("filename", ""), mesh_dir)
        if z is not None:
            r = round(float(meshes[0][1][2] - z), 4)
            notes.append(f"contact '{name}': point foot, radius {r} m = the depth of its collision mesh's lowest "
                         "point below the frame origin, along the link's -z (check it at the standing posture)")
            return None, {"kind": "point", "radius": r, "mu": 0.7}
    notes.append(f"contact '{name}': link '{link}' has no box or sphere collision "
                 f"({', '.join(sorted({c[0] for c in cols})) or 'none'}): a point contact at the frame origin; "
                 "measure the foot and set radius (m) or a sole rectangle by hand")
    return None, {"kind": "point", "mu": 0.7}


def _group_states(srdf: Path) -> list[tuple[str, dict[str, float]]]:
    root = ET.parse(srdf).getroot()
    out = []
    for gs in root.findall("group_state"):
        vals = {}
        for j in gs.findall("joint"):
            v = j.get("value", "").split()
            if len(v) == 1:
                vals[j.attrib["name"]] = float(v[0])
        out.append((gs.attrib["name"], vals))
    return out


RANGE_INSET = 0.1        # a default posture value clamped into a joint's range: this fraction of it inside


def _zero_inside_range(joints: list[ET.Element]) -> dict[str, float]:
    """{joint: value} for each revolute or prismatic joint (not a mimic) whose ``<limit>``
    range [lower, upper] (rad or m) excludes 0: the nearer limit moved ``RANGE_INSET`` of the
    range inside it, rounded to 1e-4. The zero configuration of such a joint is a state the
    robot cannot be in (the Go2's knee: [−2.72, −0.84] rad); a run started there begins
    beyond a limit, and a simulator's joint-limit constraint throws the joint into its range
    within a few milliseconds (≈ 15 rad/s)."""
    out = {}
    for j in joints:
        lim = j.find("limit")
        if j.get("type") not in ("revolute", "prismatic") or lim is None or j.find("mimic") is not None:
            continue
        lo, hi = float(lim.get("lower", 0.0)), float(lim.get("upper", 0.0))
        if lo < hi and not lo <= 0.0 <= hi:
            inset = RANGE_INSET * (hi - lo)
            out[j.attrib["name"]] = round(lo + inset if lo > 0.0 else hi - inset, 4)
    return out


def _end(joint: ET.Element, tag: str) -> str:
    """The link named by ``joint``'s ``<parent>`` or ``<child>`` (``tag``), which URDF requires."""
    el = joint.find(tag)
    if el is None:
        raise AttributeError(f"URDF joint '{joint.get('name')}' has no <{tag}>")
    return el.attrib["link"]


def _package_root(urdf: Path) -> Path | None:
    """The folder ``package://NAME/...`` mesh paths are relative to: the parent of the
    URDF's ancestor named like the package (a guess: ``share/`` of a cmeel package)."""
    for parent in urdf.parents:
        if (parent / "example-robot-data").is_dir() or parent.name == "share":
            return parent
    return urdf.parent


def guess_robot(urdf: Path, srdf: Path | None = None) -> tuple[dict, list[str]]:
    """(the robot YAML's data, notes on what could not be decided) for ``urdf``."""
    notes: list[str] = []
    tree = ET.parse(urdf).getroot()
    links = {lk.attrib["name"]: lk for lk in tree.findall("link")}
    joints = tree.findall("joint")
    children = {_end(j, "child") for j in joints}
    parent_of = {_end(j, "child"): j for j in joints}
    kids: dict[str, list[ET.Element]] = {}
    for j in joints:
        kids.setdefault(_end(j, "parent"), []).append(j)
    roots = [n for n in links if n not in children]
    root_link = roots[0]
    if len(roots) > 1:
        notes.append(f"several root links {roots}; took '{root_link}'")
    moving = [j for j in joints if j.get("type") != "fixed"]
    wheels = [j.attrib["name"] for j in moving if any(w in j.attrib["name"].lower() for w in WHEEL_WORDS)]
    wheel_links = [n for n in links if any(w in n.lower() for w in WHEEL_WORDS)]
    names_lower = " ".join(links).lower().replace("footprint", "")
    legged = any(w in names_lower for w in ("foot", "ankle", "knee", "calf", "shin"))
    if root_link == "world":
        root = "fixed"
    elif wheels or (wheel_links and not legged):
        root = "planar"
    else:
        root = "free_flyer"
        if not legged:
            notes.append("no legs or wheels found: root free_flyer guessed; a fixed arm needs root: fixed, "
                         "a mobile base root: planar")

    # end links: the leaves of the tree (links with no child joint), sensors and rotors left out
    ends = sorted(n for n in links if n != root_link and not kids.get(n))
    sensors = [n for n in ends if any(w in n.lower() for w in SENSOR_WORDS)]
    if sensors:
        notes.append(f"{len(sensors)} end links that look like sensors, rotors or wheels left out of frames: "
                     f"{', '.join(sensors[:6])}{' ...' if len(sensors) > 6 else ''}")
    ends = [n for n in ends if n not in sensors]
    frames: dict = {"base": root_link}
    contacts: dict = {}
    for n in ends:
        low = n.lower()
        if any(w in low for w in FOOT_WORDS):
            alias = re.sub(r"_?(link|frame)$", "", low)
            alias = alias if "foot" in alias else alias + "_foot"
            cols = _collisions(links[n])
            if not cols and parent_of[n].get("type") == "fixed":
                parent = _end(parent_of[n], "parent")
                if _collisions(links[parent]):
                    notes.append(f"contact '{alias}': '{n}' has no collision; the collision of its parent "
                                 f"'{parent}' was not used (its placement differs): size the sole by hand")
            frame, spec = _contact_from_collisions(alias, n, cols, notes, _package_root(urdf))
            if frame is not None:
                frames[alias.replace("foot", "sole")] = frame
                spec = {"frame": alias.replace("foot", "sole"), **spec}
            else:
                frames[alias] = n
                spec = {"frame": n, **spec}
            contacts[alias] = spec
        elif any(w in low for w in HAND_WORDS):
            frames[re.sub(r"_?(link|frame)$", "", low)] = n
        else:
            frames[re.sub(r"_?(link|frame)$", "", low) or n] = n
    if root == "free_flyer" and not contacts:
        notes.append("no foot found by name among the end links: add contacts: by hand")
    doc: dict = {"name": tree.get("name", urdf.stem), "urdf": str(urdf)}
    if srdf is not None:
        doc["srdf"] = str(srdf)
    doc["root"] = root
    doc["actuated_root"] = root == "planar"
    if wheels:
        doc["locked_joints"] = wheels
        notes.append(f"wheel joints {wheels} locked: the stack drives the base through the planar root; set "
                     "differential_drive: true for a two-wheel base, false for an omnidirectional one")
    if srdf is not None:
        states = _group_states(srdf)
        if states:
            doc["default_posture"] = states[0][0]
            if len(states) > 1:
                notes.append(f"default posture: the SRDF's first group state '{states[0][0]}' "
                             f"(others: {[s for s, _ in states[1:]]})")
        else:
            notes.append("the SRDF has no group_state: no default posture (the URDF's zero configuration)")
    else:
        inside = _zero_inside_range(moving)
        if inside:
            doc["default_posture"] = inside
            notes.append(f"no --srdf: the default posture is the zero configuration but for {sorted(inside)}, whose "
                         f"range excludes 0 (each put {100 * RANGE_INSET:g} % of its range inside its nearer limit); "
                         "give default_posture: {joint: value}")
        else:
            notes.append("no --srdf: the default posture is the zero configuration; give default_posture: "
                         "{joint: value}")
    doc["frames"] = frames
    if contacts:
        doc["contacts"] = contacts
    doc["limits"] = {}
    doc["gains"] = {"com": 100.0, "frame": 50.0, "posture": 10.0}
    torsos = sorted((n for n in links if "torso" in n.lower() and not any(w in n.lower() for w in ("imu", "sensor"))),
                    key=lambda n: (not n.lower().startswith("torso"), len(n)))
    torso = torsos[0] if torsos else None
    if root == "free_flyer" and len(contacts) == 2 and torso is not None:
        # a biped with a torso: its torso and posture gains from its inertia (wbc.robot.gains)
        frames.setdefault("torso", torso)
        doc["gains"] = {"com": 100.0, "frame": 50.0, "torso": "auto", "posture": "auto"}
        notes.append(f"gains: torso ('{torso}') and posture 'auto', derived from the robot's inertia at its "
                     "default posture (docs/robots.md); com, frame: the library's defaults (kp, 1/s²)")
    else:
        notes.append("gains are the library's defaults (kp, 1/s²): see docs/robots.md to choose them for this robot")
    return doc, notes


def dump_robot_yaml(doc: dict) -> str:
    """The robot YAML text of ``doc``: one line per key, flow style for the small mappings."""
    import yaml

    def flow(v) -> str:
        return yaml.safe_dump(v, default_flow_style=True, width=1000).strip().removesuffix("...").strip()

    lines = []
    for k, v in doc.items():
        if k in ("frames", "contacts") and isinstance(v, dict):
            lines.append(f"{k}:")
            lines += [f"  {a}: {flow(spec)}" for a, spec in v.items()]
        else:
            lines.append(f"{k}: {flow(v)}")
    return "\n".join(lines) + "\n"


def describe(robot) -> str:
    """What ``wbc robots FILE`` prints: model sizes, mass, frames, contacts, limits and the
    static-torque margin at the default posture (worst joints, |τ|/τ_max)."""
    from wbc.robot.extras import joint_name_of_v, robot_findings, static_torques

    m = robot.model
    out = [f"{robot.name}: nq {robot.nq}, nv {robot.nv}, root {robot.root}"
           f"{' (actuated)' if robot.actuated_root else ''}"
           f"{' (differential drive)' if robot.differential_drive else ''}, "
           f"mass {robot.mass:.2f} kg, CoM {np.round(robot.com, 3).tolist()} m at the default posture"]
    out.append(f"  frames:   {', '.join(f'{a} ({f})' for a, f in robot.frames.items())}")
    for c in robot.contacts.values():
        size = (f"{2 * c.half_length:g} × {2 * c.half_width:g} m sole" if c.kind == "surface"
                else f"point{f', radius {c.radius:g} m' if c.radius else ''}")
        out.append(f"  contact {c.name}: frame {c.frame}, {size}, mu {c.mu:g}")
    out.append("  joints (position limits rad or m, velocity rad/s or m/s, torque N·m or N):")
    for j in range(1, m.njoints):
        if j == 1 and m.names[j] == "root_joint":
            continue
        iq, iv = m.idx_qs[j], m.idx_vs[j]
        kind = "continuous" if m.joints[j].nq == 2 else ""
        lim = (f"[{robot.q_min[iq]:.3g}, {robot.q_max[iq]:.3g}]" if m.joints[j].nq == 1 else "unbounded")
        out.append(f"    {m.names[j]:32s} {lim:22s} v {robot.v_max[iv]:<8.3g} τ {robot.tau_max[iv]:<8.4g} {kind}")
    tau = static_torques(robot)
    ratio = np.where(np.isfinite(robot.tau_max) & (robot.tau_max > 0), np.abs(tau) / robot.tau_max, 0.0)
    worst = [i for i in np.argsort(-ratio)[:4] if ratio[i] > 0]
    if worst:
        out.append("  static torque at the default posture (gravity, held by the contacts), worst joints: " +
                   ", ".join(f"{joint_name_of_v(m, i)} {abs(tau[i]):.1f}/{robot.tau_max[i]:g} N·m "
                             f"({100 * ratio[i]:.0f} %)" for i in worst))
    if robot.default_gains:
        out.append("  gains (kp 1/s², ω = √kp rad/s): " + ", ".join(
            f"{k} {v:g} (ω {math.sqrt(v):.1f})" for k, v in robot.default_gains.items()))
    for msg in robot_findings(robot):
        out.append(f"  warning: {msg}")
    return "\n".join(out)


def _cmd_init(args) -> int:
    urdf = Path(args.urdf).resolve()
    srdf = Path(args.srdf).resolve() if args.srdf else None
    doc, notes = guess_robot(urdf, srdf)
    text = ("# written by `wbc robot init`: check every guess (the lines printed with it)\n" + dump_robot_yaml(doc))
    if args.output:
        Path(args.output).write_text(text)
        print(f"wrote {args.output}")
    else:
        print(text, end="")
    import sys

    for n in notes:
        print(f"note: {n}", file=sys.stderr)
    return 0


def _cmd_collisions(args) -> int:
    from wbc.collision.pairs import pair_file, write_pair_file
    from wbc.collision.sampling import sample_self_pairs
    from wbc.errors import ConfigError, RobotDefinitionError
    from wbc.robot.loader import load_robot

    if args.samples < 1 or not 0 < args.influence < 1:
        raise ConfigError(f"--samples must be ≥ 1 and --influence in (0, 1) m, got {args.samples}, {args.influence:g}")
    robot = load_robot(args.robot)
    if pair_file(robot) is None:
        raise RobotDefinitionError(f"robot '{robot.name}' has no YAML file to write the pairs beside")
    if args.primitives:
        return _fit_primitives(robot, args.max_excess)
    pairs, summary = sample_self_pairs(robot, influence=args.influence, samples=args.samples, seed=args.seed)
    path = write_pair_file(robot, pairs, summary)
    print(f"{robot.name}: {summary['kept']} of {summary['candidates']} self pairs come within {args.influence:g} m "
          f"in {args.samples} random configurations; wrote {path}")
    return 0


def _fit_primitives(robot, max_excess: float) -> int:
    """``wbc robot collisions ROBOT --primitives``: a capsule or a box round each geometry's hull, kept where it
    over-approximates the hull by at most ``max_excess`` (m), written to the collision file."""
    from wbc.collision.model import CollisionModel
    from wbc.collision.pairs import write_primitives
    from wbc.collision.primitives import fit_primitives
    from wbc.errors import ConfigError

    if not 0 < max_excess < 1:
        raise ConfigError(f"--max-excess must be in (0, 1) m, got {max_excess:g}")
    kept, report = fit_primitives(CollisionModel(robot, self_collision=False), max_excess)
    for name, kind, excess, ok in report:
        print(f"{name:40s} {kind:8s} over-approximates its hull by {excess * 1e3:6.1f} mm{'' if ok else ': not kept'}")
    worst = max((e for _, _, e, ok in report if ok), default=0.0)
    summary = {"method": "a capsule or a box round each geometry's convex hull (it contains every hull vertex; the "
                         "one nearer the hull), kept where its surface is at most max_excess from the hull",
               "max_excess": max_excess, "kept": len(kept), "of": len(report), "worst_excess": round(worst, 5)}
    path = write_primitives(robot, kept, summary)
    print(f"{robot.name}: {len(kept)} of {len(report)} geometries get a primitive (worst over-approximation "
          f"{worst * 1e3:.1f} mm); wrote {path}")
    return 0


def add_parser(sub) -> None:
    """Register ``wbc robot init`` on the ``wbc`` sub-command parser ``sub``."""
    p = sub.add_parser("robot", help="make a robot YAML: wbc robot init URDF [--srdf FILE] [-o OUT.yaml]",
                       description="Tools for robot YAMLs (describe one with `wbc robots FILE.yaml`).")
    s = p.add_subparsers(dest="robot_cmd", required=True, metavar="ACTION")
    i = s.add_parser("init", formatter_class=argparse.RawDescriptionHelpFormatter,
                     help="write a starting robot YAML guessed from a URDF",
                     description=__doc__.split("\n\n", 1)[1])
    i.add_argument("urdf", metavar="URDF", help="the robot's URDF")
    i.add_argument("--srdf", metavar="FILE", help="its SRDF: the first group_state becomes the default posture")
    i.add_argument("-o", "--output", metavar="OUT.yaml", help="file to write (default: standard output)")
    i.set_defaults(fn=_cmd_init)
    c = s.add_parser("collisions", help="the self pairs to monitor, written beside the robot YAML",
                     description="Every pair of the robot's collision geometries minus the SRDF's disabled pairs, "
                                 "minus adjacent links, minus pairs that never come within the influence distance "
                                 "in N random configurations inside the joint limits (the MoveIt setup assistant's "
                                 "method); written to ROBOT.collisions.yaml beside the robot YAML.")
    c.add_argument("robot", metavar="ROBOT", help="a bundled robot name or a robot YAML")
    c.add_argument("--samples", type=int, default=2000, help="random configurations (default 2000)")
    c.add_argument("--influence", type=float, default=0.05, help="influence distance d_i in m (default 0.05)")
    c.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    c.add_argument("--primitives", action="store_true",
                   help="instead: fit a capsule round each geometry's hull (containing it) and write those that "
                        "over-approximate it by at most --max-excess to the file's 'primitives:'")
    c.add_argument("--max-excess", type=float, default=0.03,
                   help="largest over-approximation of a kept capsule in m (default 0.03)")
    c.set_defaults(fn=_cmd_collisions)
