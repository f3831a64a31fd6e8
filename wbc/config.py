"""YAML -> validated objects. Every error names the file, the key path and what was
expected, e.g. ``tasks/talos_balance.yaml: stack[2][0].kp: must be >= 0, got -5``.

YAML is read with ``yaml.safe_load`` only.
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

from .errors import ConfigError, WbcError
from .stack import Stack
from .tasks import TASK_TYPES
from .tasks.base import Task
from .yamlio import read_mapping


def _accepted(cls) -> list[str]:
    return [p for p in inspect.signature(cls.__init__).parameters if p != "self"]


def build_task(spec: Any, where: str) -> Task:
    """A task from ``{type: ..., <constructor arguments>}``; ``where`` prefixes errors."""
    if not isinstance(spec, dict):
        raise ConfigError(f"{where}: expected a mapping with a 'type' key, got {type(spec).__name__}")
    if "type" not in spec:
        raise ConfigError(f"{where}.type: missing; expected one of {sorted(TASK_TYPES)}")
    kind = spec["type"]
    cls = TASK_TYPES.get(kind)
    if cls is None:
        raise ConfigError(f"{where}.type: unknown task type {kind!r}; expected one of {sorted(TASK_TYPES)}")
    kwargs = {k: v for k, v in spec.items() if k != "type"}
    accepted = _accepted(cls)
    for key in kwargs:
        if key not in accepted:
            raise ConfigError(f"{where}.{key}: unknown parameter of a '{kind}' task; expected one of {accepted}")
    for key in ("kp", "kd", "weight"):
        val = kwargs.get(key)
        if val is not None and not isinstance(val, (int, float, list)):
            raise ConfigError(f"{where}.{key}: expected a number, got {val!r}")
        if isinstance(val, (int, float)) and val < 0:
            raise ConfigError(f"{where}.{key}: must be >= 0, got {val}")
    try:
        return cls(**kwargs)
    except WbcError as exc:
        raise ConfigError(f"{where}: {exc}") from exc
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: {exc}") from exc


def build_stack(levels: Any, where: str = "stack") -> Stack:
    """A Stack from a list of levels, each a list of task mappings."""
    if not isinstance(levels, list) or not levels:
        raise ConfigError(f"{where}: expected a non-empty list of levels (each a list of tasks)")
    built = []
    for k, level in enumerate(levels):
        if not isinstance(level, list) or not level:
            raise ConfigError(f"{where}[{k}]: expected a non-empty list of tasks")
        built.append([build_task(spec, f"{where}[{k}][{i}]") for i, spec in enumerate(level)])
    try:
        return Stack(built)
    except WbcError as exc:
        raise ConfigError(f"{where}: {exc}") from exc


def read_yaml(path: str | Path) -> dict:
    """A scenario or stack YAML file as a mapping (ConfigError naming the file otherwise)."""
    return read_mapping(path, ConfigError)
