"""Hypothesis strategies that mutate YAML documents (plain data from ``yaml.safe_load``).

A case is a bundled document with 1-3 mutations applied at random key paths: a value
replaced (by junk of another type, NaN/inf, huge or tiny numbers, unicode text, lists of
the wrong length, deep nesting, or a plausible value: a scaled number, a typo, another
valid name), a key deleted, an unknown or a known optional key added, a list item
duplicated, dropped or moved. ``describe`` says what was done, for a failing example.
"""

from __future__ import annotations

import copy
import math
from typing import Any

from hypothesis import strategies as st

#: names that exist somewhere in the bundled robots and scenarios (plausible references)
NAMES = ["left_foot", "right_foot", "left_hand", "right_hand", "torso", "base", "head", "hand", "elbow",
         "left_foot_contact", "right_foot_contact", "right_swing", "com", "posture", "joint_limits",
         "torque_limits", "left_sole_link", "arm_left_4_link", "torso_2_link", "base_link", "root_joint",
         "arm_left_1_joint", "leg_right_4_joint", "gripper_left_joint", "wheel_left_joint", "arm_1_joint",
         "panda_joint1", "panda_hand", "universe", "hqp", "projection", "weighted", "daqp", "proxqp", "osqp",
         "sinusoid", "waypoints", "constant", "ground", "box", "incline", "surface", "point", "pose",
         "position", "orientation", "xy", "z", "identity", "inertia", "half_sitting", "default",
         "contact", "frame", "contact_wrench", "null_space_impedance", "contact_regularization", "free_flyer",
         "planar", "fixed", "mujoco", "pinocchio"]
#: keys wbc knows somewhere (added where they may not belong)
KEYS = ["type", "kp", "kd", "weight", "name", "target", "axes", "mask", "frame", "contact", "mu", "fmin",
        "bilateral", "cop_margin", "joints", "dt", "horizon", "max_acceleration", "margin", "scale", "k_q",
        "B_nu", "normal_weight", "trajectory", "offset", "amplitude", "frequency", "phase", "ramp", "absolute",
        "times", "points", "value", "time", "duration", "level", "release", "add", "touchdown", "remove",
        "force", "start", "noise_q", "noise_v", "latency_steps", "substeps", "backend", "weighting",
        "level_weight", "height", "angle", "center", "size", "limits", "torque", "velocity", "root_torque",
        "root_velocity", "kind", "half_length", "half_width", "srdf", "urdf", "package", "path",
        "locked_joints", "base_position", "frames", "contacts", "gains", "default_posture", "actuated_root",
        "differential_drive", "level_on_contacts", "description", "acceptance", "events", "pushes", "stack",
        "environment", "sensing", "solver", "control", "robot", "simulator"]

#: values a key may well have (added as a known key, they make unusual but valid documents)
PLAUSIBLE = {
    "kp": [0.0, 1.0, 400.0, [10.0, 20.0, 30.0], [1.0] * 6, 1e6], "kd": [0.0, 5.0, [1.0, 2.0, 3.0]],
    "weight": [0.1, 1e-6, 10.0], "name": ["extra", "right_swing", "com"], "axes": ["xy", "z", "xyz", "yx"],
    "mask": ["pose", "position", "orientation", [1, 0, 1, 0, 0, 0], [True, False, True, False, False, True]],
    "target": [[0.0, 0.03, 0.85], [0.1, 0.2, 0.3], {"position": [0.3, -0.2, 0.9]}],
    "mu": [0.3, 1.0, 5.0], "fmin": [0.0, 10.0, 50.0], "bilateral": [True, False], "cop_margin": [0.0, 0.5],
    "joints": [["arm_left_1_joint", "arm_left_2_joint"], ["leg_left_4_joint"], ["arm_1_joint"]],
    "dt": [0.002, 0.0005, 0.01], "horizon": [0.05, 1.0], "max_acceleration": [5.0, 100.0], "margin": [0.01, 0.1],
    "scale": [0.5, 1.0], "offset": [[0.0, 0.0, 0.01], [0.05, -0.05, 0.0]], "absolute": [True, False],
    "trajectory": [{"type": "sinusoid", "amplitude": [0.0, 0.02, 0.0], "frequency": 1.0},
                   {"type": "constant", "value": [0.01, 0.0, 0.0]},
                   {"type": "waypoints", "times": [0.0, 0.5], "points": [[0, 0, 0], [0.0, 0.0, 0.02]]}],
    "phase": [0.0, 1.5708, -3.0], "ramp": [0.0, 0.5, 2.0], "frequency": [0.1, 2.0, 10.0],
    "substeps": [1, 2, 4], "backend": ["daqp", "proxqp"], "weighting": ["identity", "inertia"],
    "level_weight": [1e-3, 0.1, 1.0], "type": ["hqp", "projection", "weighted", "com", "posture"],
    "noise_q": [0.0, 1e-4], "noise_v": [0.0, 1e-3], "latency_steps": [0, 1, 3], "height": [0.0, -0.01, 0.01],
    "angle": [0.0, 0.05], "level": [0, 1, 2, 5], "duration": [0.05, 1.0, 4.0], "time": [0.0, 0.5, 1.0],
    "pushes": [[{"frame": "torso", "force": [20.0, 0.0, 0.0], "start": 0.0, "duration": 0.1}]],
    "sensing": [{"noise_q": 1e-5, "latency_steps": 1}], "solver": [{"type": "projection"}, {"type": "weighted"}],
    "environment": [[{"type": "ground", "mu": 0.5}], [], [{"type": "incline", "angle": 0.02, "mu": 0.9}]],
    "level_on_contacts": [True, False], "actuated_root": [True, False], "differential_drive": [True, False],
    "half_length": [0.05, 0.2], "half_width": [0.03], "kind": ["point", "surface"],
    "base_position": [[0.0, 0.0], [0.1, 0.2, 1.1]], "gains": [{"com": 50.0}],
    "locked_joints": [["arm_left_7_joint"], ["gripper_left_joint"], ["wheel_left_joint"], ["head_1_joint"]],
    "limits": [{"torque": {"arm_left_1_joint": 50.0}}, {"velocity": {"head_1_joint": 1.0}}],
    "simulator": ["pinocchio", "mujoco"],
}

floats = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, 1e-300, 5e-324, 1e300, 1.7e308, -1e300]),
    st.floats(-10, 10, allow_nan=False),
)
ints = st.one_of(st.integers(-10, 10), st.integers(-2**70, 2**70), st.sampled_from([10**400, -10**400, 2**63, 0]))
texts = st.one_of(
    st.text(max_size=12),
    st.sampled_from(["", " ", "1e-3", "0.5", "nan", "inf", ".inf", "yes", "NaN", "~", "null", "true", "1_000",
                     "ё", "右手", "🤖", "a" * 300, "left_foot\n", "\u202e", "0x10", "1:30"]),
    st.sampled_from(NAMES),
)
scalars = st.one_of(st.none(), st.booleans(), ints, floats, texts)


#: what a number may be replaced by (the classes of value a number check must refuse or survive)
SPECIAL_NUMBERS = [math.nan, math.inf, -math.inf, 1.7e308, -1.7e308, 1e-308, 5e-324, 0.0, -0.0, -1.0, 1e9, -1e9,
                   10**400, 2**64, "1e-3", "0.5", ".nan", True, False, None, [], [1.0, 2.0], "fast"]


def _nested(depth: int) -> Any:
    value: Any = 1.0
    for _ in range(depth):
        value = [value]
    return value


junk = st.one_of(
    scalars,
    st.lists(st.one_of(floats, ints), max_size=8),
    st.lists(scalars, max_size=5),
    st.lists(st.lists(floats, max_size=4), max_size=4),
    st.dictionaries(st.one_of(st.sampled_from(KEYS), st.text(max_size=6)), scalars, max_size=4),
    st.integers(2, 45).map(_nested),
)


def paths(doc: Any, prefix: tuple = ()) -> list[tuple]:
    """Every key path of ``doc`` below the root (mapping keys and list indices)."""
    out = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            out.append(prefix + (k,))
            out.extend(paths(v, prefix + (k,)))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out.append(prefix + (i,))
            out.extend(paths(v, prefix + (i,)))
    return out


def containers(doc: Any, prefix: tuple = ()) -> list[tuple]:
    """Key paths of every mapping and list in ``doc``, the root included."""
    out = [prefix] if isinstance(doc, (dict, list)) else []
    if isinstance(doc, dict):
        for k, v in doc.items():
            out.extend(containers(v, prefix + (k,)))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out.extend(containers(v, prefix + (i,)))
    return out


def get(doc: Any, path: tuple) -> Any:
    for k in path:
        doc = doc[k]
    return doc


def _typo(word: str, draw) -> str:
    if not word:
        return "x"
    i = draw(st.integers(0, len(word) - 1))
    how = draw(st.sampled_from(["drop", "double", "swap", "case"]))
    if how == "drop":
        return word[:i] + word[i + 1:] or "x"
    if how == "double":
        return word[:i] + word[i] + word[i:]
    if how == "swap" and i + 1 < len(word):
        return word[:i] + word[i + 1] + word[i] + word[i + 2:]
    return word.upper() if word != word.upper() else word.lower() + "x"


def _plausible(value: Any, draw) -> Any:
    """A value of the same kind as ``value``, often still valid."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, (int, float)):
        factor = draw(st.sampled_from([0.0, -1.0, 0.5, 2.0, 1e-3, 1e3, 1e9, 1.0 + 1e-12]))
        if isinstance(value, int) and abs(value) > 2**1000:
            return -value if factor < 0 else value // 2
        out = value * factor
        return int(out) if isinstance(value, int) and math.isfinite(out) and draw(st.booleans()) else out
    if isinstance(value, str):
        return draw(st.one_of(st.sampled_from(NAMES), st.just(_typo(value, draw))))
    if isinstance(value, list):
        if not value:
            return [draw(scalars)]
        how = draw(st.sampled_from(["drop", "dup", "append", "each"]))
        if how == "drop":
            return value[:-1]
        if how == "dup":
            return value + [copy.deepcopy(value[-1])]
        if how == "append":
            return value + [draw(st.one_of(floats, ints))]
        return [_plausible(v, draw) for v in value]
    return draw(junk)


@st.composite
def mutated(draw, documents: list[tuple[str, Any]], max_mutations: int = 3) -> tuple[str, Any, list[str]]:
    """(base name, mutated document, what was done) from one of ``documents``."""
    name, base = draw(st.sampled_from(documents))
    doc = copy.deepcopy(base)
    done = []
    for _ in range(draw(st.sampled_from([1, 1, 1, 2, max_mutations]))):
        how = draw(st.sampled_from(["junk", "plausible", "plausible", "delete", "unknown_key", "known_key",
                                    "known_key", "list_edit", "graft", "special", "special"]))
        if how in ("unknown_key", "known_key"):
            where = draw(st.sampled_from([p for p in containers(doc) if isinstance(get(doc, p), dict)] or [()]))
            target = get(doc, where)
            if not isinstance(target, dict):
                continue
            if how == "unknown_key":
                key = draw(st.one_of(st.text(min_size=1, max_size=8),
                                     st.just(_typo(draw(st.sampled_from(list(target) or ["x"])), draw))
                                     if target else st.just("x")))
            else:
                key = draw(st.sampled_from(KEYS))
            if how == "unknown_key":
                value = draw(st.one_of(junk, st.sampled_from(NAMES)))
            elif key in PLAUSIBLE and draw(st.integers(0, 2)) > 0:
                value = copy.deepcopy(draw(st.sampled_from(PLAUSIBLE[key])))
            else:
                value = draw(st.one_of(junk, st.sampled_from(NAMES), st.just(copy.deepcopy(target.get(key, 1.0)))))
            target[key] = value
            done.append(f"{how} {where}+{key!r}={value!r:.60}")
            continue
        if how == "list_edit":
            lists = [p for p in containers(doc) if isinstance(get(doc, p), list) and get(doc, p)]
            if not lists:
                continue
            where = draw(st.sampled_from(lists))
            lst = get(doc, where)
            op = draw(st.sampled_from(["dup", "drop", "move", "clear"]))
            i = draw(st.integers(0, len(lst) - 1))
            if op == "dup":
                lst.insert(i, copy.deepcopy(lst[i]))
            elif op == "drop":
                del lst[i]
            elif op == "move":
                lst.insert(draw(st.integers(0, len(lst) - 1)), lst.pop(i))
            else:
                lst.clear()
            done.append(f"list_{op} {where}[{i}]")
            continue
        all_paths = paths(doc)
        if how == "special":
            numeric = [p for p in all_paths
                       if isinstance(get(doc, p), (int, float)) and not isinstance(get(doc, p), bool)]
            if not numeric:
                continue
            path = draw(st.sampled_from(numeric))
            value = copy.deepcopy(draw(st.sampled_from(SPECIAL_NUMBERS)))
            get(doc, path[:-1])[path[-1]] = value
            done.append(f"special {path}={value!r:.60}")
            continue
        if not all_paths:
            continue
        path = draw(st.sampled_from(all_paths))
        parent, key = get(doc, path[:-1]), path[-1]
        if how == "delete":
            del parent[key]
            done.append(f"delete {path}")
        elif how == "junk":
            parent[key] = draw(junk)
            done.append(f"junk {path}={parent[key]!r:.60}")
        elif how == "plausible":
            parent[key] = _plausible(parent[key], draw)
            done.append(f"plausible {path}={parent[key]!r:.60}")
        else:       # graft: a subtree from elsewhere in the document
            source = draw(st.sampled_from(all_paths))
            parent[key] = copy.deepcopy(get(doc, source))
            done.append(f"graft {path}<-{source}")
    return name, doc, done
