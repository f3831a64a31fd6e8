"""Numba's on-disk caches, kept consistent across the package's kernel files.

Numba caches a compiled kernel keyed by its own source file's date and size only. A kernel
that calls a kernel of another file (the cascade run calls the factorisations, the QP rows
and the certified active sets) keeps its cached machine code, with the callee inlined,
after the callee's file changes: the old mathematics runs silently. :func:`drop_stale`
prevents that: a digest of every kernel file's source (and of numba's version) is stored
beside the caches; when it differs, every cache entry of those files is deleted before a
kernel is loaded, so all of them are compiled again. It runs once when ``wbc`` is
imported (the kernels compile or load at their first call, later). ``make clean-cache``
does the same by hand.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numba

#: the package's directory; every ``*.py`` in it that defines a numba kernel is covered
PACKAGE = Path(__file__).resolve().parent
STAMP = "wbc-kernels.stamp"


def kernel_files(root: Path = PACKAGE) -> list[Path]:
    """The package's source files that define numba kernels, sorted."""
    return sorted(p for p in root.rglob("*.py") if "njit" in p.read_text(encoding="utf-8"))


def digest(files: list[Path]) -> str:
    """SHA-256 of numba's version and of each file's name and source."""
    h = hashlib.sha256(numba.__version__.encode())
    for p in files:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def cache_dir(source: Path) -> Path | None:
    """Where numba keeps the caches of ``source``'s kernels: its own locators, in their
    order (next to the file, else the user-wide cache directory), or None if it gives none."""
    caching = numba.core.caching
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    for locator in getattr(impl, "_locator_classes", ()):
        try:
            found = locator.from_function(digest, str(source))
        except Exception:           # a locator that does not apply to this file
            found = None
        if found is not None:
            return Path(found.get_cache_path())
    return None


def drop_stale(root: Path = PACKAGE) -> int:
    """Delete every kernel cache of the files under ``root`` when their sources changed
    since the caches were written; returns the number of cache files deleted. Never
    raises: a cache directory it cannot write only leaves numba's own behaviour."""
    try:
        files = kernel_files(root)
        stamp = digest(files)
        dirs: dict[Path, list[Path]] = {}
        for p in files:
            d = cache_dir(p)
            if d is not None:
                dirs.setdefault(d, []).append(p)
        deleted = 0
        for d, sources in dirs.items():
            mark = d / STAMP
            if mark.is_file() and mark.read_text() == stamp:
                continue
            if d.is_dir():
                for p in sources:
                    for cached in list(d.glob(f"{p.stem}.*.nbi")) + list(d.glob(f"{p.stem}.*.nbc")):
                        cached.unlink(missing_ok=True)
                        deleted += 1
            d.mkdir(parents=True, exist_ok=True)
            mark.write_text(stamp)
        return deleted
    except OSError:
        return 0
