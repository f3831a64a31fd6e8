"""Numba's caches across kernel files (wbc.kernel_cache): a change to any kernel file drops
the caches of every kernel file, so a caller never keeps a callee's old machine code."""

from __future__ import annotations

from pathlib import Path

from wbc.kernel_cache import STAMP, cache_dir, drop_stale, kernel_files


def _tree(tmp_path: Path) -> tuple[Path, Path, Path]:
    (tmp_path / "caller.py").write_text("import numba\n@numba.njit(cache=True)\ndef f(x):\n    return g(x)\n")
    (tmp_path / "callee.py").write_text("import numba\n@numba.njit(cache=True)\ndef g(x):\n    return x\n")
    (tmp_path / "plain.py").write_text("X = 1\n")
    d = cache_dir(tmp_path / "caller.py")
    assert d is not None
    d.mkdir(parents=True, exist_ok=True)
    cached = d / "caller.f-2.py313.nbi"
    return d, cached, tmp_path / "callee.py"


def test_a_changed_callee_drops_the_callers_cache(tmp_path):
    d, cached, callee = _tree(tmp_path)
    assert [p.name for p in kernel_files(tmp_path)] == ["callee.py", "caller.py"]
    drop_stale(tmp_path)                     # first sight: stamp written
    assert (d / STAMP).is_file()
    cached.write_text("machine code")
    (d / "caller.f-2.py313.nbc").write_text("data")
    (d / "other.h-1.py313.nbi").write_text("not ours")
    assert drop_stale(tmp_path) == 0 and cached.exists()          # nothing changed: kept
    callee.write_text(callee.read_text().replace("return x", "return 2 * x"))
    assert drop_stale(tmp_path) == 2                               # the callee changed
    assert not cached.exists() and not (d / "caller.f-2.py313.nbc").exists()
    assert (d / "other.h-1.py313.nbi").exists()                    # not a kernel file's cache
    assert drop_stale(tmp_path) == 0


def test_the_package_is_stamped_on_import():
    import wbc.solvers.kernels.factorizations as f

    d = cache_dir(Path(f.__file__))
    assert d is not None and (d / STAMP).is_file()
