"""The machine a bench ran on: what it is, and how fast its BLAS is at the cascade's sizes."""

from __future__ import annotations

import os
import platform
import time
from importlib import metadata

import numpy as np

from wbc.blas import openblas_libs


def svd_probe(sizes=(24, 48, 96), reps: int = 20) -> dict:
    """Median time (ms) of numpy's full SVD of an n × n matrix (what the cascade does per
    level), with the current BLAS threads and with one thread."""
    libs = openblas_libs()
    rng = np.random.default_rng(0)
    out = {}
    for n in sizes:
        A = rng.standard_normal((n, n))
        row = {}
        for mode in ("default", "1 thread"):
            saved = [get() for _, get, _ in libs]
            if mode == "1 thread":
                for _, _, put in libs:
                    put(1)
            ts = []
            for _ in range(reps):
                t0 = time.perf_counter()
                np.linalg.svd(A, full_matrices=True)
                ts.append(time.perf_counter() - t0)
            for (_, _, put), s in zip(libs, saved):
                put(s)
            row[mode] = float(np.median(ts) * 1e3)
        out[str(n)] = row
    return out


def machine_info() -> dict:
    """CPU, cores, platform, Python and package versions, BLAS threads per loaded
    OpenBLAS, the thread variables of the environment and the load average."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for ln in fh:
                if ln.startswith("model name"):
                    cpu = ln.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    versions = {}
    for pkg in ("numpy", "scipy", "pin", "daqp", "proxsuite", "quadprog", "osqp", "qpsolvers", "placo"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    import scipy.linalg  # noqa: F401
    blas = {os.path.basename(p): get() for p, get, _ in openblas_libs()}
    info = {"cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "numpy": versions["numpy"], "pin": versions["pin"],
            "versions": versions, "blas_threads": blas,
            "env_threads": {k: os.environ[k] for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
                            if k in os.environ}}
    try:
        info["load_average_start"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    return info
