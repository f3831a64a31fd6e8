"""The summary of a sweep, as Markdown (printed, and written to ``summary.md``).

Counts per status; per group (``summary.group_by``: by default the grid and choice axes
of a random sweep, every grid axis but the last of a grid sweep) the number of cases and
the fraction that survived, with its 95 % Wilson interval; for a bisection, the limit
found per group (the largest value that survived and the smallest that did not).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from .criteria import unmatched
from .engine import SweepResult
from .store import cell

STATUSES = ("ok", "fell", "error", "failed", "timeout")


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a fraction k / n."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (max(0.0, c - h), min(1.0, c + h))


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return cell(v)


def groups(records: list[dict], keys: list[str]) -> dict[tuple, list[dict]]:
    """Records by the values of ``keys``, in order of first appearance."""
    out: dict[tuple, list[dict]] = {}
    for r in records:
        out.setdefault(tuple(cell(r.get(k)) for k in keys), []).append(r)
    return out


def _criterion(res: SweepResult) -> str:
    ops = {"eq": "==", "max": "<=", "min": ">="}
    return ", ".join(f"{c.column} {ops[c.op]} {_fmt(c.value)}" for c in res.spec.survive) or "(none)"


def markdown(res: SweepResult, command: str | None = None) -> str:
    """The summary of ``res`` (module docstring)."""
    spec, recs = res.spec, res.records
    st = Counter(r.get("status") for r in recs)
    lines = [f"# Sweep {spec.path.name}: {spec.mode}, base {spec.base.stem}", ""]
    if command:
        lines += [f"Reproduce: `{command}`", ""]
    lines += [f"- cases: {len(recs)} (this run: {res.ran} run, "
              f"{res.skipped} from results.csv{', stopped early' if res.stopped else ''}); executor "
              f"{res.executor}{f' × {res.workers}' if res.workers else ''}, {res.elapsed_s:.0f} s",
              "- status: " + ", ".join(f"{s} {st[s]}" for s in STATUSES if st[s]),
              f"- survived: status ok and {_criterion(res)}"]
    miss = unmatched(recs, spec.survive)
    if miss:
        lines.append(f"- warning: no case reports {', '.join(miss)}: that condition fails every case")
    walls = [r["wall_s"] for r in recs
             if isinstance(r.get("wall_s"), (int, float)) and r.get("status") in ("ok", "fell")]
    if walls:
        lines.append(f"- wall time per case: median {sorted(walls)[len(walls) // 2]:.2f} s, max {max(walls):.2f} s")
    lines.append("")
    if res.groups:
        axis = spec.bisect_axis
        assert axis is not None, "bisection groups exist only for a bisect axis"
        keys = [a.key for a in spec.grid_axes]
        lines += ["| " + " | ".join([*keys, f"largest survived {axis.key}", "first failed", "probes"]) + " |",
                  "|" + " --- |" * (len(keys) + 3)]
        for g, b in res.groups:
            lim = b.limit
            failed = "-" if b.outcome == "at_least_hi" else _fmt(b.hi if b.outcome != "below_lo" else b.lo)
            shown = ("-" if lim is None else _fmt(lim)) + (" (upper bound)" if b.outcome == "at_least_hi" else "") + \
                ("" if b.done else " (unfinished)")
            lines.append("| " + " | ".join([*(_fmt(g[k]) for k in keys), shown, failed, str(len(b.probes))]) + " |")
    else:
        keys = spec.group_by
        lines += ["| " + " | ".join([*(keys or ["all cases"]), "cases", "survived", "fraction", "95 % interval",
                                     "not run to the end"]) + " |", "|" + " --- |" * (max(1, len(keys)) + 5)]
        for gk, rs in groups(recs, keys).items():
            k, n = sum(bool(r.get("survived")) for r in rs), len(rs)
            lo, hi = wilson(k, n)
            bad = sum(r.get("status") in ("error", "failed", "timeout") for r in rs)
            lines.append("| " + " | ".join([*(gk or ("all",)), str(n), str(k), f"{k / n:.3f}", f"{lo:.2f}-{hi:.2f}",
                                            str(bad)]) + " |")
    errors = [r for r in recs if r.get("status") in ("error", "failed", "timeout")]
    if errors:
        lines += ["", "Cases that did not run to their end (first 10):", ""]
        lines += [f"- case {r['case']} ({r['hash']}): {r['status']}: {r.get('error') or ''}" for r in errors[:10]]
    return "\n".join(lines) + "\n"
