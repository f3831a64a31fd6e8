"""The run's OpenBLAS thread count (wbc.blas.blas_threads): one thread during the loop by
default, each library's own count back after it; ``blas_threads=None`` leaves it."""

from __future__ import annotations

import pytest

from wbc.blas import blas_thread_counts, blas_threads, set_blas_threads
from wbc.runner.loop import run
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config

pytestmark = pytest.mark.skipif(not blas_thread_counts(), reason="no OpenBLAS found in this process's memory map")


def _counts_seen(**settings) -> tuple[list[list[int]], list[int]]:
    """The BLAS thread counts seen at every cycle of a short talos_balance run, and after it,
    the libraries set to 2 threads before it."""
    seen: list[list[int]] = []
    set_blas_threads(2)
    try:
        run(load_config(SCENARIOS_DIR / "talos_balance.yaml"), duration=0.01,
            callback=lambda t, sim, sol: seen.append(blas_thread_counts()), **settings)
        return seen, blas_thread_counts()
    finally:
        set_blas_threads(1)


def test_the_loop_runs_on_one_blas_thread_and_gives_the_count_back():
    seen, after = _counts_seen()
    assert len(seen) == 10
    assert all(c == [1] * len(c) for c in seen), seen
    assert after == [2] * len(after)


def test_none_leaves_the_count_as_found():
    seen, after = _counts_seen(blas_threads=None)
    assert all(c == [2] * len(c) for c in seen), seen
    assert after == [2] * len(after)


def test_the_count_is_restored_when_the_block_raises():
    set_blas_threads(3)
    try:
        with pytest.raises(RuntimeError), blas_threads(1):
            assert blas_thread_counts() == [1] * len(blas_thread_counts())
            raise RuntimeError
        assert blas_thread_counts() == [3] * len(blas_thread_counts())
        with pytest.raises(ValueError, match="at least 1"), blas_threads(0):
            pass
    finally:
        set_blas_threads(1)
