"""Running one case inside a worker process (a local pool's or a Ray worker's).

:func:`execute` builds the case's scenario through :func:`wbc.scenario.loader.load_config` (the
same checks as ``wbc validate``: the resolved document is written to a temporary YAML
file), runs it with :func:`wbc.runner.loop.run` and returns a plain dict: ``status`` (``ok``,
``fell`` (also a run stopped early: its ``stopped`` metric) or ``error``), ``error`` (the
message of an exception the case raised), ``metrics`` (flattened, :func:`flatten`) and ``wall_s`` (s). It never raises for a bad
case; a case that kills or hangs its process is the executor's to record (``failed``,
``timeout``).

Each worker process loads a robot once per robot name (or path) and reuses it for
every later case (:func:`robot_loader`; a run leaves no state in the RobotModel that the
next one reads, which ``tests/sweep/test_sweep.py`` checks by comparing executors), runs BLAS
on one thread (the pool has one process per core) and shares numba's on-disk kernel
cache with every other process.
"""

from __future__ import annotations

import os
import signal
import tempfile
import time
from pathlib import Path
from typing import Any

#: metrics left out of the rows: wall-clock timings (they differ between runs of one
#: case, and results must not) and what the row has already
DROPPED = ("series", "cycle_time", "real_time_factor", "scenario")

_robots: dict[str, Any] = {}
_blas_set = False


def robot_loader(name_or_path) -> Any:
    """``wbc.robot.loader.load_robot``, cached in this process by name (or path)."""
    from wbc.robot.loader import load_robot

    key = str(name_or_path)
    if key not in _robots:
        _robots[key] = load_robot(name_or_path)
    return _robots[key]


def flatten(metrics: dict, prefix: str = "") -> dict[str, Any]:
    """Nested metrics as ``{"tasks.com.rms": ..., "com_final[0]": ...}`` without :data:`DROPPED`."""
    out: dict[str, Any] = {}
    for k, v in metrics.items():
        if not prefix and k in DROPPED:
            continue
        key = f"{prefix}.{k}" if prefix else str(k)
        if isinstance(v, dict):
            out.update(flatten(v, key))
        elif isinstance(v, (list, tuple)):
            for i, x in enumerate(v):
                if isinstance(x, dict):
                    out.update(flatten(x, f"{key}[{i}]"))
                else:
                    out[f"{key}[{i}]"] = _scalar(x)
        else:
            out[key] = _scalar(v)
    return out


def _scalar(v: Any) -> Any:
    """A numpy scalar as the Python one (rows hold plain values)."""
    return v.item() if hasattr(v, "item") and not isinstance(v, (str, bytes)) else v


def _one_blas_thread() -> None:
    global _blas_set
    if not _blas_set:
        try:
            from ..blas import set_blas_threads

            set_blas_threads(1)
        except Exception:        # no OpenBLAS found: nothing to set
            pass
        _blas_set = True


def _injected(what: list[str]) -> None:
    """Fault injection for testing the executors (spec ``inject:``)."""
    if "crash" in what:
        os.kill(os.getpid(), signal.SIGSEGV)
    if "hang" in what:
        while True:
            time.sleep(3600)
    if "raise" in what:
        raise RuntimeError("injected failure (inject.raise)")


def build(payload: dict):
    """The :class:`~wbc.scenario.loader.Scenario` of a case payload (ConfigError if it does not
    build) and the perturbation for the runner (or None)."""
    import yaml

    from wbc.scenario.loader import load_config

    from .perturb import Perturbation, perturbed_robot

    pert = Perturbation(payload["perturbation"]["mass_scale"], dict(payload["perturbation"]["link_scale"]),
                        payload["perturbation"]["apply_to"])
    loader = robot_loader
    if not pert.identity and pert.apply_to in ("controller", "both"):
        def loader(name):
            return perturbed_robot(robot_loader(name), pert)
    doc = payload["doc"]
    with tempfile.TemporaryDirectory(prefix="wbc-sweep-") as tmp:
        path = Path(tmp) / f"{doc.get('name', 'case')}.case-{payload['hash']}.yaml"
        path.write_text(yaml.safe_dump(doc, sort_keys=False))
        sc = load_config(path, robot_loader=loader)
    sim_pert = pert if not pert.identity and pert.apply_to in ("simulator", "both") else None
    if sim_pert is not None and getattr(sc, "simulator", "pinocchio") != "pinocchio":
        from ..errors import ConfigError

        raise ConfigError(f"model.* perturbs the pinocchio model the simulator steps; simulator "
                          f"'{sc.simulator}' builds its own model (use model.apply_to: controller)", key="model")
    if sc.sensing.get("noise_q") or sc.sensing.get("noise_v"):
        sc.sensing["seed"] = int(payload["seed"])      # the case's own noise sequence
    return sc, sim_pert


def execute(payload: dict) -> dict:
    """Run one case (module docstring); never raises for a bad case."""
    t0 = time.perf_counter()
    _one_blas_thread()
    try:
        _injected(payload.get("inject", []))
        from wbc.runner.loop import run

        sc, sim_pert = build(payload)
        metrics = run(sc, model_perturbation=sim_pert)
        flat = flatten(metrics)
        # a run stopped early (a controller stop, a diverged simulation: wbc.controller.faults) did not
        # run to its end: it never survives, its metrics are kept, like a fall's
        status = "fell" if metrics.get("fell") or metrics.get("stopped") else "ok"
        return {"status": status, "error": "", "metrics": flat, "wall_s": time.perf_counter() - t0}
    except Exception as exc:          # the case's failure, recorded; the sweep goes on
        msg = f"{type(exc).__name__}: {exc}"
        return {"status": "error", "error": msg.replace("\n", " ")[:2000], "metrics": {},
                "wall_s": time.perf_counter() - t0}
