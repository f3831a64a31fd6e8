"""Cases of a sweep: the axes' values of each, its resolved scenario document, its hash.

A case is resolved once, in the driver: the base scenario's YAML data with ``set:`` and
the case's axis values applied by key path (:func:`wbc.sweep.keypath.apply_all`), the
``model.*`` values turned into a :class:`~wbc.sweep.perturb.Perturbation`. Its ``hash``
(16 hex digits) is the SHA-256 of that document, the perturbation and the seed, in
canonical JSON: the same case gets the same hash in any process, on any machine and in
any order, which is what the results store resumes by (editing the base scenario, or the
robot YAML it names, changes the hashes, so its cases run again).

Seeds: ``grid`` and ``bisect`` cases share the spec's ``seed`` (common random numbers:
solvers compared under the same sensor noise); in ``random`` mode draw ``i`` has seed
``seed + i`` and its values come from ``numpy.random.default_rng([seed, i])`` alone, so
adding samples adds cases and leaves the earlier ones (and their hashes) as they were.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..jsonable import plain
from . import keypath
from .axes import Axis
from .perturb import Perturbation, perturbation
from .spec import SweepSpec

#: bump when the meaning of a resolved case changes (the runner's inputs, the hash's layout);
#: 2: the robot YAML's content is hashed too
CASE_VERSION = 2


@dataclass(eq=False)
class Case:
    """One run: ``values`` (axis key -> value), the resolved scenario ``doc`` and
    ``perturbation``, ``seed``, ``hash``; ``index`` names it in the sweep (``"17"``,
    ``"3.1"`` for draw 3 × grid point 1, ``"g2.h"`` for a bisection probe)."""

    index: str
    values: dict[str, Any]
    seed: int
    doc: dict
    perturbation: Perturbation
    hash: str
    group: int | None = None
    inject: set[str] = field(default_factory=set)

    def payload(self) -> dict:
        """What a worker needs to run the case (plain data: picklable, small)."""
        return {"doc": self.doc, "perturbation": self.perturbation.as_dict(), "seed": self.seed,
                "hash": self.hash, "inject": sorted(self.inject)}


def case_hash(doc: dict, pert: Perturbation, seed: int) -> str:
    """Stable 16-hex-digit hash of a resolved case: its document, perturbation and seed, and
    the content of the robot YAML its ``robot:`` names (a bundled name or a path), so that
    editing the robot (its gains, say) runs the case again instead of resuming a stale
    result."""
    blob = json.dumps({"v": CASE_VERSION, "doc": doc, "model": pert.as_dict(), "seed": seed,
                       "robot_file": robot_file_digest(doc.get("robot"))},
                      sort_keys=True, separators=(",", ":"), allow_nan=True, default=plain)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def robot_file_digest(robot: Any) -> str:
    """SHA-256 of the data of the robot YAML a ``robot:`` value names, in canonical JSON (a
    comment or a layout edit is the same robot); "" for an inline robot, or for a name or
    file that gives none (the case then fails with that error when it runs)."""
    if not isinstance(robot, str):
        return ""
    import yaml

    from wbc.robot.loader import robot_yaml_path

    from ..errors import WbcError

    try:
        data = yaml.safe_load(robot_yaml_path(robot).read_text(encoding="utf-8"))
    except (WbcError, OSError, UnicodeError, yaml.YAMLError):
        return ""
    blob = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def make_case(spec: SweepSpec, values: dict[str, Any], seed: int, index: str, group: int | None = None) -> Case:
    """Resolve one case (module docstring). Raises ConfigError (message only, no key) when a
    key path does not fit the base document."""
    scen = {**{k: v for k, v in spec.fixed.items() if not k.startswith("model.")},
            **{k: v for k, v in values.items() if not k.startswith("model.")}}
    model = {**{k: v for k, v in spec.fixed.items() if k.startswith("model.")},
             **{k: v for k, v in values.items() if k.startswith("model.")}}
    doc = keypath.apply_all(spec.base_doc, scen)
    pert = perturbation(model)
    inject = {what for what, cond in spec.inject.items() if all(_same(values.get(k), v) for k, v in cond.items())}
    return Case(index, dict(values), seed, doc, pert, case_hash(doc, pert, seed), group, inject)


def _same(a: Any, b: Any) -> bool:
    return json.dumps(a, sort_keys=True, default=plain) == json.dumps(b, sort_keys=True, default=plain)


def grid_points(axes: list[Axis]) -> list[dict[str, Any]]:
    """Every combination of the grid axes' values, the first axis varying slowest."""
    if not axes:
        return [{}]
    return [dict(zip([a.key for a in axes], combo)) for combo in itertools.product(*(a.values for a in axes))]


def draw(axes: list[Axis], seed: int, i: int) -> dict[str, Any]:
    """Draw ``i`` of the random axes (uniform on a range, uniform among choices)."""
    rng = np.random.default_rng([seed, i])
    out: dict[str, Any] = {}
    for a in axes:
        if a.kind == "range":
            out[a.key] = int(rng.integers(int(a.lo), int(a.hi) + 1)) if a.integer else \
                float(a.lo + (a.hi - a.lo) * rng.random())
        elif a.kind == "choices":
            out[a.key] = a.values[int(rng.integers(len(a.values)))]
    return out


def static_cases(spec: SweepSpec) -> list[Case]:
    """The cases of a ``grid`` or ``random`` sweep, in a fixed order."""
    grid = grid_points(spec.grid_axes)
    if spec.mode == "grid":
        return [make_case(spec, g, spec.seed, str(i)) for i, g in enumerate(grid)]
    rand = [a for a in spec.axes if a.random]
    out = []
    for i in range(spec.samples):
        d = draw(rand, spec.seed, i)
        for j, g in enumerate(grid):
            values = {a.key: (d[a.key] if a.key in d else g[a.key]) for a in spec.axes}
            out.append(make_case(spec, values, spec.seed + i, f"{i}" if len(grid) == 1 else f"{i}.{j}"))
    return out


def ordered_values(spec: SweepSpec, values: dict[str, Any]) -> dict[str, Any]:
    """``values`` in the spec's axis order."""
    return {a.key: values[a.key] for a in spec.axes if a.key in values}
