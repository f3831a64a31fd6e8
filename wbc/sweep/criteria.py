"""The survival criterion of a sweep (``survive:``), evaluated on a result row.

A condition names a metric column (``tasks.com.final``, ``contacts.left_foot.lifted``);
``*`` matches one part of a name (``contacts.*.lifted``: every contact), and every
column it matches must satisfy it; a pattern that matches no column fails (a criterion
on a metric the run did not report is not met). A case survives when it ran to its end
(status ``ok``; a fall, an error, a crash or a time-out never survives) and every
condition holds. The same function judges a fresh row and one read back from the CSV,
so changing ``survive:`` re-judges stored cases without running them.
"""

from __future__ import annotations

import math
import re
from typing import Any

from .spec import Condition


def _pattern(column: str) -> re.Pattern:
    return re.compile("^" + r"[^.\[\]]*".join(re.escape(p) for p in column.split("*")) + "$")


def matching(column: str, row: dict[str, Any]) -> list[str]:
    """The row's columns that the (possibly wildcard) ``column`` names."""
    if "*" not in column:
        return [column] if column in row and row[column] is not None else []
    pat = _pattern(column)
    return [c for c in row if pat.match(c) and row[c] is not None]


def holds(cond: Condition, value: Any) -> bool:
    """Whether one value satisfies ``cond``."""
    if cond.op == "eq":
        if isinstance(cond.value, bool) or isinstance(value, bool):
            return isinstance(value, bool) and value == cond.value
        if isinstance(cond.value, (int, float)) and isinstance(value, (int, float)):
            return float(value) == float(cond.value)
        return value == cond.value
    if not isinstance(value, (int, float)) or isinstance(value, bool) or math.isnan(value):
        return False
    return value <= cond.value if cond.op == "max" else value >= cond.value


def survived(row: dict[str, Any], conditions: list[Condition]) -> bool:
    """Whether the case of ``row`` survived (module docstring)."""
    if row.get("status") != "ok":
        return False
    for cond in conditions:
        cols = matching(cond.column, row)
        if not cols or not all(holds(cond, row[c]) for c in cols):
            return False
    return True


def unmatched(rows: list[dict[str, Any]], conditions: list[Condition]) -> list[str]:
    """Conditions no row that ran has a column for (worth a warning: they fail every case)."""
    ran = [r for r in rows if r.get("status") == "ok"]
    return [c.column for c in conditions if ran and not any(matching(c.column, r) for r in ran)]
