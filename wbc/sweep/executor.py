"""What the sweep driver needs of an executor, and how one is chosen.

An executor runs :class:`Job` s (a case's hash and payload) and reports :class:`Outcome` s:

- ``capacity``: cases it runs at once (the driver keeps that many submitted);
- ``submit(job)``: queue a case;
- ``wait(timeout)``: the outcomes of the cases that ended within ``timeout`` s (maybe
  none), every case that raised, crashed its process or overran the per-case time-out
  included (status ``error``, ``failed``, ``timeout``);
- ``close()``: stop, abandoning what still runs.

:class:`wbc.sweep.local.LocalPool` (processes on this machine, the default) and
:class:`wbc.sweep.ray_pool.RayPool` (Ray tasks, on a laptop or a cluster) implement it;
both call :func:`wbc.sweep.worker.execute` on the same payloads, so the results are the
same whichever runs them.
"""

from __future__ import annotations

from .jobs import Executor


def make_executor(kind: str, *, workers: int | None = None, timeout: float = 300.0, address: str | None = None,
                  runtime_env: dict | None = None) -> Executor:
    """``kind`` ``local`` or ``ray`` (ray imported only then: ``pip install 'wbc[sweep]'``)."""
    if kind == "local":
        from .local import LocalPool

        return LocalPool(workers, timeout)
    if kind == "ray":
        from .ray_pool import RayPool

        return RayPool(workers=workers, timeout=timeout, address=address, runtime_env=runtime_env)
    raise ValueError(f"unknown executor {kind!r}; expected local or ray")
