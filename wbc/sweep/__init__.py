"""``wbc sweep``: parameter sweeps and Monte Carlo studies of a scenario, on a local process
pool or a Ray cluster, with results that resume after an interruption.

    from wbc.sweep import load_spec, run_sweep
    spec = load_spec("benchmarks/push_recovery.yaml")
    res = run_sweep(spec, workers=2)          # res.records: one dict per case

Modules, one idea each: :mod:`~wbc.sweep.spec` (the spec YAML, checked),
:mod:`~wbc.sweep.keypath` (key paths into a scenario document, the one setter),
:mod:`~wbc.sweep.perturb` (model perturbations), :mod:`~wbc.sweep.cases` (cases, hashes,
grid and random draws), :mod:`~wbc.sweep.bisect` (per-group bisection),
:mod:`~wbc.sweep.validate` (``--validate``), :mod:`~wbc.sweep.worker` (one case in a
worker process), :mod:`~wbc.sweep.executor`, :mod:`~wbc.sweep.local`,
:mod:`~wbc.sweep.ray_pool` (executors), :mod:`~wbc.sweep.store` (the CSV),
:mod:`~wbc.sweep.criteria` (survival), :mod:`~wbc.sweep.engine` (the driver),
:mod:`~wbc.sweep.summary`, :mod:`~wbc.sweep.plots`, :mod:`~wbc.cli.sweep` (the command).
Nothing heavy is imported here: ``wbc --help`` stays fast.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.jsonable`, :mod:`wbc.blas`,
:mod:`wbc.robot`, :mod:`wbc.scenario`, :mod:`wbc.runner`. Not the CLI (its command is :mod:`wbc.cli.sweep`).
"""

from __future__ import annotations


def load_spec(path):
    """:func:`wbc.sweep.spec.load_spec`."""
    from .spec import load_spec as _load

    return _load(path)


def run_sweep(spec, **kwargs):
    """:func:`wbc.sweep.engine.run_sweep`."""
    from .engine import run_sweep as _run

    return _run(spec, **kwargs)


__all__ = ["load_spec", "run_sweep"]
