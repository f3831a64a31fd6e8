"""The results store: one CSV row per finished case, appended and flushed as each ends.

Columns: :data:`LEADING` (``case``, ``group``, ``hash``, ``seed``, ``status``,
``survived``, ``wall_s`` in s, ``error``), then the axes' key paths, then the flattened
metrics (``fell``, ``solver_failures``, ``tasks.com.rms``, ``contacts.left_foot.slip``, ...
in SI units). A row is written and flushed to disk (``fsync``) when its case ends, so a
sweep that is interrupted keeps every case it finished; on the next run the store is read
back and the cases whose hash it holds are skipped. A case that brings a column the file
does not have yet (a metric of another robot, the first metrics after error rows) has the
file rewritten with the wider header (atomically: a temporary file, then a rename). A
last line cut short by a kill is dropped on reading.

Cells: numbers as Python writes them (``repr``: they read back exactly), ``true`` /
``false``, lists and mappings as JSON, text as it is; empty = no value.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path
from typing import Any

LEADING = ("case", "group", "hash", "seed", "status", "survived", "wall_s", "error")
#: columns read back as text whatever they look like (a hash may be all digits)
TEXT = ("case", "hash", "status", "error")
#: statuses of a case that ran to its end (its metrics are in the row)
RAN = ("ok", "fell")
#: statuses a rerun with ``retry`` runs again
RETRY = ("error", "failed", "timeout")


def cell(v: Any) -> str:
    """A value as CSV text (module docstring)."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) and not math.isfinite(v) else repr(v)
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v, separators=(", ", ": "))
    return str(v)


def parse_cell(s: str) -> Any:
    """Inverse of :func:`cell`."""
    if s == "":
        return None
    if s in ("true", "false"):
        return s == "true"
    if s[0] in "[{":
        try:
            return json.loads(s)
        except ValueError:
            return s
    try:
        return int(s)
    except ValueError:
        pass
    try:
        return float(s)
    except ValueError:
        return s


class ResultStore:
    """Rows by case hash, backed by the CSV at ``path`` (created with its folder)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.columns: list[str] = []
        self.rows: dict[str, dict[str, Any]] = {}
        if self.path.exists():
            self._read()

    def _read(self) -> None:
        raw = self.path.read_text()
        complete = raw if raw.endswith("\n") or not raw else raw[: raw.rfind("\n") + 1]
        lines = list(csv.reader(complete.splitlines(keepends=True)))
        if not lines:
            return
        self.columns = lines[0]
        for vals in lines[1:]:
            if len(vals) != len(self.columns):
                continue                       # a row cut short (killed mid-write)
            row = {c: (v if c in TEXT else parse_cell(v)) for c, v in zip(self.columns, vals)}
            if row.get("hash"):
                self.rows[str(row["hash"])] = row
        if complete != raw:
            self._rewrite()

    def __contains__(self, key: str) -> bool:
        return key in self.rows

    def get(self, key: str) -> dict[str, Any] | None:
        return self.rows.get(key)

    def add(self, row: dict[str, Any]) -> None:
        """Store ``row`` (replacing a row of the same hash) and write it to disk now."""
        key = str(row["hash"])
        replaced = key in self.rows
        self.rows[key] = row
        new = [c for c in row if c not in self.columns]
        if new or replaced:
            self.columns += new
            self._rewrite()
            return
        with self.path.open("a", newline="") as f:
            csv.writer(f).writerow([cell(row.get(c)) for c in self.columns])
            f.flush()
            os.fsync(f.fileno())

    def _rewrite(self) -> None:
        tmp = self.path.with_name(self.path.name + ".tmp")
        with tmp.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(self.columns)
            for r in self.rows.values():
                w.writerow([cell(r.get(c)) for c in self.columns])
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)
