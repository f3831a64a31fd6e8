"""The types an executor and the sweep driver share: a :class:`Job` in, an :class:`Outcome`
out, the :class:`Executor` protocol (see :mod:`wbc.sweep.executor`) and the worker count."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Protocol


@dataclass(frozen=True)
class Job:
    """One case to run: its ``key`` (the case hash) and worker ``payload``."""

    key: str
    payload: dict = field(hash=False, compare=False)


@dataclass
class Outcome:
    """How a job ended: ``status`` (ok, fell, error, failed, timeout), ``error`` text,
    flattened ``metrics`` (empty unless it ran to its end), ``wall_s`` (s)."""

    job: Job
    status: str
    error: str
    metrics: dict[str, Any]
    wall_s: float


class Executor(Protocol):
    capacity: int

    def submit(self, job: Job) -> None: ...
    def wait(self, timeout: float) -> list[Outcome]: ...
    def close(self) -> None: ...


def default_workers() -> int:
    """Cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:           # not Linux
        return max(1, os.cpu_count() or 1)
