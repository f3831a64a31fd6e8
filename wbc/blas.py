"""The OpenBLAS thread count of this process: read it and set it, at run time.

Why: the cascade's factorisations (QR, SVD of matrices of a few dozen rows, see
``wbc/solvers/``) are far too small for BLAS threads to pay; on a shared machine a
multi-threaded OpenBLAS spins its threads and makes the cycle slower and noisier. ``wbc
bench --blas-threads N`` sets the count before measuring (and its SVD probe times both),
and each sweep worker (``wbc.sweep.worker``) runs on one thread, the pool having one
process per core. ``wbc run`` (:func:`wbc.runner.loop.run`) runs its loop on one thread
by default (:func:`blas_threads`; ``--blas-threads N`` / ``RunOptions.blas_threads``).

How: ``OPENBLAS_NUM_THREADS`` is read only when a library is loaded, and numpy and scipy
each load their own OpenBLAS (the ``scipy_openblas`` wheels, whose symbols carry a
``scipy_`` prefix and a ``64_`` suffix for the 64-bit-integer build). So the loaded
libraries are found in the process's memory map (``/proc/self/maps``, Linux; elsewhere none
is found and the functions do nothing) and their ``openblas_set_num_threads`` /
``openblas_get_num_threads`` are called through :mod:`ctypes`. (threadpoolctl does the same
for every BLAS; it is not a dependency of wbc.)
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Iterator
from contextlib import contextmanager

#: (symbol prefix, symbol suffix) of OpenBLAS's thread functions, most specific first
_SYMBOLS = (("scipy_openblas_", "64_"), ("scipy_openblas_", ""), ("openblas_", "64_"), ("openblas_", ""))


def openblas_libs() -> list[tuple[str, Callable[[], int], Callable[[int], None]]]:
    """(path, get_num_threads, set_num_threads) of every OpenBLAS this process has loaded
    (none where ``/proc/self/maps`` does not exist)."""
    libs: list[tuple[str, Callable[[], int], Callable[[int], None]]] = []
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({ln.split()[-1] for ln in fh if "openblas" in ln.lower() and ln.split()[-1].startswith("/")})
    except OSError:
        return libs
    for p in paths:
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        for pre, suf in _SYMBOLS:
            get, put = getattr(lib, f"{pre}get_num_threads{suf}", None), getattr(lib, f"{pre}set_num_threads{suf}", None)
            if get is not None and put is not None:
                libs.append((p, get, put))
                break
    return libs


def set_blas_threads(n: int) -> None:
    """Every loaded OpenBLAS (numpy's and scipy's: scipy.linalg is imported first so that
    its own library is loaded too) runs on ``n`` threads from now on."""
    import scipy.linalg  # noqa: F401  (load scipy's own OpenBLAS too)

    for _, _, put in openblas_libs():
        put(int(n))


def blas_thread_counts() -> list[int]:
    """The thread count of every loaded OpenBLAS, in :func:`openblas_libs`'s order."""
    return [int(get()) for _, get, _ in openblas_libs()]


@contextmanager
def blas_threads(n: int | None) -> Iterator[None]:
    """Every loaded OpenBLAS on ``n`` threads inside the block (:func:`set_blas_threads`),
    each back on its own count after it; ``n`` None leaves them as they are.

    Args:
        n: the thread count inside the block (≥ 1), or None.
    """
    if n is None:
        yield
        return
    if int(n) < 1:
        raise ValueError(f"BLAS thread count {n}: expected at least 1 (or None to leave it)")
    import scipy.linalg  # noqa: F401  (load scipy's own OpenBLAS first: its count is restored too)

    libs = openblas_libs()
    before = [get() for _, get, _ in libs]
    set_blas_threads(n)
    try:
        yield
    finally:
        for (_, _, put), k in zip(libs, before, strict=True):
            put(int(k))
