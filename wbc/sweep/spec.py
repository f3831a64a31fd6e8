"""The sweep spec YAML: read (``yaml.safe_load`` semantics, :mod:`wbc.validation.yamlio`) and checked.

    base: talos_push                  # bundled scenario, or a path relative to this file
    mode: bisect                      # grid (default) | random | bisect
    seed: 0                           # random draws and the simulator's sensor noise
    set:                              # fixed changes to every case (key path: value)
      duration: 2.0
      pushes[0].start: 0.5
    axes:                             # key path: values
      solver.type: [hqp, projection]                 # a list: grid values
      pushes[0].force@direction_deg: {linspace: [0, 315, 8]}
      pushes[0].force@magnitude: {bisect: {lo: 0, hi: 800, tol: 10}}
    survive: {fell: false, tasks.com.final: {max: 0.005}, contacts.*.lifted: false}
    timeout: 120                      # s per case, then the case is killed (status timeout)
    executor: {type: local, workers: 2}             # or {type: ray, address: auto}
    output: results/push              # folder of results.csv, summary.md, plots (default: <spec stem>/)

An axis is ``[v, ...]`` or ``{values: [...]}`` (grid), ``{linspace: [lo, hi, n]}`` (grid),
``{range: [lo, hi]}`` (random, uniform; ``integer: true`` for whole numbers),
``{choices: [...]}`` (random), ``{bisect: {lo, hi, tol}}`` (the largest value in [lo, hi]
that survives, to ``tol``, in the axis's units; ``integer: true`` for whole numbers).
``grid``: grid axes only; ``random``: ``samples`` draws of the random axes, each crossed with
the grid axes; ``bisect``: one bisect axis, searched once per point of the grid axes.

Key paths are those of the scenario's error messages (:mod:`wbc.sweep.keypath`, with
``@magnitude`` / ``@direction_deg`` for a horizontal 3-vector) and ``model.*`` (model
perturbations, :mod:`wbc.sweep.perturb`). ``survive:`` maps a metric column (flattened
metrics, ``*`` one part of any name) to a value (equal), or ``{max: x}`` / ``{min: x}``;
the default is ``{fell: false, solver_failures: 0}``. A case that did not run to its end
(error, failed, timeout) never survives.

Also: ``samples: N`` (random mode), ``summary: {group_by: [axis keys]}`` (the groups of the
survived fractions), ``plots: {histograms: [metric columns]}``, ``description:``, and
``inject: {raise|hang|crash: {axis key: value}}``: fault injection for testing the
executors (the matching cases raise, sleep forever, or kill their process with SIGSEGV).
The axes in detail: :mod:`wbc.sweep.axes`.

Errors are :class:`~wbc.errors.ConfigError` naming the spec file, the line and the key path.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from wbc.runner.metrics import BOOLEAN_METRICS
from wbc.validation.schema import integer, mapping, number, sequence, text
from wbc.validation.yamlio import Document, read_document

from ..errors import ConfigError, WbcError, placed
from .axes import MAX_CASES, Axis, check_key, check_mode, grid_size, max_probes, parse_axis

MODES = ("grid", "random", "bisect")
EXECUTORS = ("local", "ray")
_TOP = {"base", "mode", "seed", "samples", "set", "axes", "survive", "timeout", "executor", "output",
        "summary", "plots", "description", "inject"}
#: default survival criterion
DEFAULT_SURVIVE = {"fell": False, "solver_failures": 0}
DEFAULT_TIMEOUT = 300.0


@dataclass(frozen=True)
class Condition:
    """``column`` (a flattened-metric name, ``*`` matching one part) ``op`` (eq, max, min) ``value``."""

    column: str
    op: str
    value: Any


@dataclass
class SweepSpec:
    """A checked sweep spec (module docstring); ``base_doc`` is the base scenario's YAML data."""

    path: Path
    base: Path
    base_doc: dict
    mode: str
    axes: list[Axis]
    fixed: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    samples: int = 0
    survive: list[Condition] = field(default_factory=list)
    timeout: float = DEFAULT_TIMEOUT
    executor: dict = field(default_factory=lambda: {"type": "local"})
    output: Path = Path(".")
    group_by: list[str] = field(default_factory=list)
    histograms: list[str] = field(default_factory=list)
    inject: dict = field(default_factory=dict)
    doc: Document | None = None

    def line(self, key: str) -> int | None:
        return self.doc.line(key) if self.doc is not None else None

    def error(self, message: str, key: str | None) -> ConfigError:
        """A ConfigError at ``key`` of this spec file."""
        return ConfigError(message, key=key, file=self.path, line=self.line(key))

    @property
    def grid_axes(self) -> list[Axis]:
        return [a for a in self.axes if a.kind == "values"]

    @property
    def bisect_axis(self) -> Axis | None:
        return next((a for a in self.axes if a.kind == "bisect"), None)


def load_spec(path: str | Path) -> SweepSpec:
    """Read and check the sweep spec at ``path`` (structure only: :func:`wbc.sweep.validate.check`
    also builds cases). Raises :class:`ConfigError` naming the file, line and key path."""
    src = Path(path)
    doc = read_document(src, ConfigError)
    try:
        return _build(doc, src)
    except WbcError as exc:
        if exc.file is not None:
            raise
        raise placed(exc, file=src, line=doc.line(exc.key), cls=ConfigError) from exc


def _build(doc: Document, src: Path) -> SweepSpec:
    cfg = mapping(doc.data, None, allowed=_TOP, required=("base", "axes"))
    base = _base_path(cfg["base"], src)
    base_doc = _base_doc(base)
    mode = text(cfg.get("mode", "grid"), "mode", choices=MODES)
    seed = integer(cfg.get("seed", 0), "seed", ge=0, le=2**63 - 1)
    axes_cfg = mapping(cfg["axes"], "axes")
    if not axes_cfg:
        raise ConfigError("must name at least one axis (key path: values)", key="axes")
    axes = [parse_axis(k, v) for k, v in axes_cfg.items()]
    fixed = {}
    for k, v in mapping(cfg.get("set"), "set").items():
        check_key(k, f"set.{k}")
        fixed[k] = _robot_value(k, v, src)
    axes = [Axis(a.key, a.kind, tuple(_robot_value(a.key, v, src) for v in a.values), a.lo, a.hi, a.tol,
                 a.integer) for a in axes]
    samples = 0
    if mode == "random":
        if "samples" not in cfg:
            raise ConfigError("missing: mode random needs samples: N (the number of random draws)", key="samples")
        samples = integer(cfg["samples"], "samples", ge=1, le=MAX_CASES)
    elif "samples" in cfg:
        raise ConfigError(f"samples applies to mode random only (mode is {mode})", key="samples")
    check_mode(mode, axes)
    out_default = src.parent / src.stem
    spec = SweepSpec(
        path=src, base=base, base_doc=base_doc, mode=mode, axes=axes, fixed=fixed, seed=seed, samples=samples,
        survive=_survive(cfg.get("survive", DEFAULT_SURVIVE)),
        timeout=number(cfg.get("timeout", DEFAULT_TIMEOUT), "timeout", gt=0, le=7 * 86400, unit="s per case"),
        executor=_executor(cfg.get("executor")),
        output=(src.parent / text(cfg["output"], "output", what="a folder")) if "output" in cfg else out_default,
        doc=doc)
    spec.group_by, spec.histograms = _summary(cfg, spec)
    spec.inject = _inject(cfg.get("inject"), spec)
    n = count_cases(spec)
    if n > MAX_CASES:
        raise ConfigError(f"{n} cases: more than {MAX_CASES}", key="axes")
    return spec


def _base_path(value: Any, src: Path) -> Path:
    from wbc.scenario.examples import scenario_path

    name = text(value, "base", what="a bundled scenario name or a path to a scenario YAML")
    p = Path(name)
    try:
        return scenario_path(src.parent / p if p.suffix in (".yaml", ".yml") or len(p.parts) > 1 else name)
    except WbcError as exc:
        raise placed(exc, "base", cls=ConfigError) from exc


def _base_doc(base: Path) -> dict:
    """The base scenario's YAML data, with a ``name`` and its ``robot`` path made absolute."""
    data = read_document(base, ConfigError).data
    data.setdefault("name", base.stem)
    robot = data.get("robot")
    if isinstance(robot, str) and robot.endswith((".yaml", ".yml")) and not os.path.isabs(robot):
        data["robot"] = str((base.parent / robot).resolve())
    return data


def _robot_value(key: str, value: Any, src: Path) -> Any:
    """A ``robot`` value that is a relative path is relative to the spec file."""
    if key == "robot" and isinstance(value, str) and value.endswith((".yaml", ".yml")) and not os.path.isabs(value):
        return str((src.parent / value).resolve())
    return value


def _is_boolean_metric(column: str) -> bool:
    """Whether ``column`` names one of the run's true/false metrics (``BOOLEAN_METRICS``),
    wildcards on either side matching one part of a name."""
    parts = column.split(".")
    for name in BOOLEAN_METRICS:
        known = name.split(".")
        if len(known) == len(parts) and all(a == b or "*" in (a, b) for a, b in zip(parts, known)):
            return True
    return False


def _survive(spec: Any) -> list[Condition]:
    out = []
    for col, v in mapping(spec, "survive").items():
        where = f"survive.{col}"
        if isinstance(v, dict):
            m = mapping(v, where, allowed={"max", "min"})
            if not m:
                raise ConfigError("give max: or min:", key=where)
            out += [Condition(col, op, number(m[op], f"{where}.{op}")) for op in ("max", "min") if op in m]
        elif isinstance(v, (bool, int, float, str)):
            if _is_boolean_metric(col) and not isinstance(v, bool):
                raise ConfigError(f"is a true/false metric: give true or false, got {v!r}", key=where)
            out.append(Condition(col, "eq", v))
        else:
            raise ConfigError(f"must be a value (equal) or {{max: x}} / {{min: x}}, got {v!r}", key=where)
    return out


def _executor(spec: Any) -> dict:
    e = mapping(spec if spec is not None else {}, "executor", allowed={"type", "workers", "address", "runtime_env"})
    out: dict = {"type": text(e.get("type", "local"), "executor.type", choices=EXECUTORS)}
    if "workers" in e:
        out["workers"] = integer(e["workers"], "executor.workers", ge=1, le=4096)
    if "address" in e:
        out["address"] = text(e["address"], "executor.address", what="a Ray address (auto, ray://host:10001)")
    if "runtime_env" in e:
        out["runtime_env"] = mapping(e["runtime_env"], "executor.runtime_env")
    if out["type"] == "local" and ({"address", "runtime_env"} & set(e)):
        raise ConfigError("address and runtime_env apply to type: ray", key="executor")
    return out


def _summary(cfg: dict, spec: SweepSpec) -> tuple[list[str], list[str]]:
    keys = [a.key for a in spec.axes]
    s = mapping(cfg.get("summary"), "summary", allowed={"group_by"})
    if "group_by" in s:
        group_by = [text(g, f"summary.group_by[{i}]", choices=keys)
                    for i, g in enumerate(sequence(s["group_by"], "summary.group_by"))]
    elif spec.mode == "bisect":
        group_by = [a.key for a in spec.grid_axes]
    elif spec.mode == "random":
        group_by = [a.key for a in spec.axes if a.kind in ("values", "choices")]
    else:
        group_by = keys[:-1]
    p = mapping(cfg.get("plots"), "plots", allowed={"histograms"})
    hist = [text(h, f"plots.histograms[{i}]", what="a metric column")
            for i, h in enumerate(sequence(p.get("histograms", ["tasks.com.rms", "support_margin_min"]),
                                           "plots.histograms"))]
    return group_by, hist


def _inject(spec: Any, sweep: SweepSpec) -> dict:
    """``inject: {raise|hang|crash: {axis key: value}}`` (testing the machinery): a case whose
    axis values match raises, sleeps forever or kills its own process (SIGSEGV)."""
    keys = {a.key for a in sweep.axes}
    out = {}
    for what, cond in mapping(spec, "inject", allowed={"raise", "hang", "crash"}).items():
        cond = mapping(cond, f"inject.{what}")
        for k in cond:
            if k not in keys:
                raise ConfigError(f"must be an axis key; axes: {sorted(keys)}", key=f"inject.{what}.{k}")
        out[what] = dict(cond)
    return out


def count_cases(spec: SweepSpec) -> int:
    """Number of cases (bisect: the most the searches can take)."""
    grid = grid_size(spec.axes)
    if spec.mode == "random":
        return spec.samples * grid
    if spec.mode == "bisect":
        return grid * max_probes(spec.bisect_axis)
    return grid
