"""The Ray executor: the same cases as Ray tasks, on this machine or a cluster.

``pip install 'wbc[sweep]'`` (ray[default] 2.60); ray is imported only when this executor
is asked for. ``address`` None starts a local Ray with ``workers`` CPUs (default: the
cores) whose workers run at the driver's priority, as the local pool's do (not at Ray's
default nice 15); ``"auto"`` joins the cluster this machine is part of,
``"ray://head:10001"`` a remote one; if Ray is already initialised (``ray.init`` by the
caller, e.g. with a ``ray.cluster_utils.Cluster``) that connection is used. Every node
needs wbc installed (the same version), or a ``runtime_env`` that provides it.

Each case is a task ``execute(payload)`` (:func:`wbc.sweep.worker.execute`) with
``num_cpus=1`` and no retries. At most ``capacity`` tasks (the cluster's CPUs, or
``workers``) are in flight, so a task starts when it is submitted: one that has no
result ``timeout`` s after submission (the first task of a fresh Ray worker process
includes its start-up, ~2-3 s) is cancelled with ``ray.cancel(force=True)``, which kills
its worker process, and recorded as ``timeout``; a task whose worker process or node
died is ``failed``. Ray worker processes are reused between tasks, so each keeps its
loaded robots.
"""

from __future__ import annotations

import time
from collections import deque

from ..errors import ConfigError
from .jobs import Job, Outcome


def import_ray():
    """``import ray``, or a ConfigError saying how to install it."""
    try:
        import ray
    except ImportError as exc:
        raise ConfigError(f"executor ray needs the ray package ({exc}); install it with "
                          "pip install 'wbc[sweep]' (ray[default] >= 2.60)", key="executor.type") from None
    return ray


class RayPool:
    """Executor over Ray tasks (module docstring). ``timeout``: s per case."""

    name = "ray"

    def __init__(self, workers: int | None = None, timeout: float = 300.0, address: str | None = None,
                 runtime_env: dict | None = None) -> None:
        ray = self._ray = import_ray()
        self.timeout = float(timeout)
        self._owned = False
        if not ray.is_initialized():
            # Ray lowers its workers' priority (nice 15) by default; a sweep's workers are the work
            kw = dict(include_dashboard=False, log_to_driver=False, runtime_env=runtime_env)
            if address is None:
                kw["_system_config"] = {"worker_niceness": 0}
            if address is None and workers:
                kw["num_cpus"] = int(workers)
            ray.init(address=address, **kw)
            self._owned = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.capacity = max(1, min(cpus, int(workers)) if workers else cpus)
        from .worker import execute

        self._fn = ray.remote(num_cpus=1, max_retries=0)(execute)
        self._queue: deque[Job] = deque()
        self._inflight: dict = {}          # ObjectRef -> (job, submitted at)

    def submit(self, job: Job) -> None:
        """Queue ``job``; it is sent to Ray when fewer than ``capacity`` tasks are in flight."""
        self._queue.append(job)

    def _dispatch(self) -> None:
        while self._queue and len(self._inflight) < self.capacity:
            job = self._queue.popleft()
            self._inflight[self._fn.remote(job.payload)] = (job, time.perf_counter())

    def wait(self, timeout: float) -> list[Outcome]:
        """Outcomes of the tasks that ended within ``timeout`` s (possibly none)."""
        ray = self._ray
        self._dispatch()
        out: list[Outcome] = []
        if self._inflight:
            now = time.perf_counter()
            first = min(t for _, t in self._inflight.values()) + self.timeout - now
            refs = list(self._inflight)
            ready, _ = ray.wait(refs, num_returns=1, timeout=max(0.0, min(timeout, first)))
            if ready:
                ready, _ = ray.wait(refs, num_returns=len(refs), timeout=0)
            for ref in ready:
                job, t0 = self._inflight.pop(ref)
                out.append(self._outcome(ref, job, t0))
            now = time.perf_counter()
            for ref, (job, t0) in list(self._inflight.items()):
                if now - t0 > self.timeout:
                    ray.cancel(ref, force=True)
                    del self._inflight[ref]
                    out.append(Outcome(job, "timeout", f"no result after {self.timeout:g} s: task cancelled", {},
                                       now - t0))
        elif timeout > 0 and not self._queue:
            time.sleep(min(timeout, 0.05))
        self._dispatch()
        return out

    def _outcome(self, ref, job: Job, t0: float) -> Outcome:
        ray = self._ray
        exc_mod = ray.exceptions
        try:
            res = ray.get(ref)
        except exc_mod.RayTaskError as exc:          # the task raised outside execute's own guard
            return Outcome(job, "error", f"{type(exc).__name__}: {str(exc).splitlines()[0]}"[:2000], {},
                           time.perf_counter() - t0)
        except exc_mod.RayError as exc:              # worker process or node died
            return Outcome(job, "failed", f"{type(exc).__name__}: {str(exc).splitlines()[0]}"[:2000], {},
                           time.perf_counter() - t0)
        return Outcome(job, res["status"], res["error"], res["metrics"], res["wall_s"])

    def close(self) -> None:
        """Cancel what still runs; shut Ray down if this pool started it."""
        for ref in list(self._inflight):
            try:
                self._ray.cancel(ref, force=True)
            except Exception:
                pass
        self._inflight.clear()
        self._queue.clear()
        if self._owned:
            self._ray.shutdown()
