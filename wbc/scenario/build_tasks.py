"""YAML -> validated objects. Every error names the file, the key path and what was
expected, e.g. ``tasks/talos_balance.yaml:17: stack[2][0].kp: must be a number >= 0 (1/s²), got -5``.

YAML is read with ``yaml.safe_load`` only.
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

from wbc.errors import ConfigError, WbcError, placed
from wbc.options import flat_parameters
from wbc.stack import Stack
from wbc.tasks import TASK_TYPES
from wbc.tasks.base import Task
from wbc.validation.schema import mapping, sequence, show, suggest
from wbc.validation.yamlio import read_mapping


def _parameters(cls) -> dict[str, inspect.Parameter]:
    """The keys a task mapping may hold: the constructor's parameters, its options record's
    fields in place of ``options`` and ``**settings``."""
    return flat_parameters(cls.__init__, cls.options_record)


def build_task(spec: Any, where: str) -> Task:
    """A task from ``{type: ..., <constructor arguments>}``; ``where`` is its key path.

    The mapping's keys are checked here (type, unknown and missing parameters); the values
    by the task's constructor, whose errors (with the parameter's key) come out as a
    :class:`ConfigError` under ``where``."""
    spec = mapping(spec, where, required=("type",), what="a task mapping with a 'type' key")
    kind = spec["type"]
    if not isinstance(kind, str) or kind not in TASK_TYPES:
        hint = suggest(kind, TASK_TYPES) if isinstance(kind, str) else ""
        raise ConfigError(f"unknown task type {show(kind)}{hint}; expected one of {sorted(TASK_TYPES)}",
                          key=f"{where}.type")
    cls = TASK_TYPES[kind]
    params = _parameters(cls)
    accepted = list(params)
    kwargs = {k: v for k, v in spec.items() if k != "type"}
    for key in kwargs:
        if key not in accepted:
            raise ConfigError(f"unknown parameter of a '{kind}' task{suggest(key, accepted)}; expected one of "
                              f"{accepted}", key=f"{where}.{key}")
    for name, p in params.items():
        if p.default is inspect.Parameter.empty and name not in kwargs:
            raise ConfigError(f"missing (required by a '{kind}' task)", key=f"{where}.{name}")
    try:
        return cls(**kwargs)
    except WbcError as exc:
        raise placed(exc, where, cls=ConfigError) from exc


def build_stack(levels: Any, where: str = "stack") -> Stack:
    """A Stack from a list of levels, each a list of task mappings."""
    levels = sequence(levels, where, min_len=1, what="a non-empty list of levels (each a list of tasks)")
    built = []
    for k, level in enumerate(levels):
        level = sequence(level, f"{where}[{k}]", min_len=1, what="a non-empty list of tasks")
        built.append([build_task(spec, f"{where}[{k}][{i}]") for i, spec in enumerate(level)])
    try:
        return Stack(built)
    except WbcError as exc:
        raise placed(exc, where, cls=ConfigError) from exc


def read_yaml(path: str | Path) -> dict:
    """A scenario or stack YAML file as a mapping (ConfigError naming the file otherwise)."""
    return read_mapping(path, ConfigError)
