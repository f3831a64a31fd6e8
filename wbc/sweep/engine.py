"""The sweep driver: cases -> executor -> results store, bisections, progress, resume.

:func:`run_sweep` enumerates the spec's cases (:mod:`wbc.sweep.cases`), skips those the
results store already holds (by hash), sends the rest to the executor and writes each
row as its case ends. In ``bisect`` mode every group's search (:mod:`wbc.sweep.bisect`)
is first replayed from the stored rows, then advanced one probe at a time as results
arrive, all groups at once. Cases of equal hash (e.g. a zero push in every direction)
run once and serve every place they appear. A progress line (done, failed, rate, ETA)
goes to stderr.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..options import Options
from .axes import max_probes
from .bisect import Bisection
from .cases import Case, grid_points, make_case, ordered_values, static_cases
from .criteria import survived
from .executor import make_executor
from .jobs import Executor, Job, Outcome
from .spec import SweepSpec
from .store import RETRY, ResultStore


@dataclass
class SweepResult:
    """What a sweep produced. ``records``: one dict per case of the spec, in the spec's
    order (its axis values, then its stored row; ``survived`` judged by the spec);
    ``groups``: per bisection group its grid values and :class:`Bisection`."""

    spec: SweepSpec
    out_dir: Path
    records: list[dict[str, Any]] = field(default_factory=list)
    groups: list[tuple[dict, Bisection]] = field(default_factory=list)
    ran: int = 0
    skipped: int = 0
    stopped: bool = False
    elapsed_s: float = 0.0
    executor: str = "local"
    workers: int = 0

    def count(self, status: str) -> int:
        return sum(r.get("status") == status for r in self.records)


class Progress:
    """One line on stderr, rewritten: done/total, errors, rate, ETA (s)."""

    def __init__(self, total: int, enabled: bool, stream=None) -> None:
        self.total, self.enabled, self.stream = total, enabled, stream or sys.stderr
        self.t0 = time.perf_counter()
        self.done = 0
        self.bad: dict[str, int] = {}
        self._last = 0.0

    def update(self, status: str | None = None, total: int | None = None, force: bool = False) -> None:
        if status is not None:
            self.done += 1
            if status in RETRY:
                self.bad[status] = self.bad.get(status, 0) + 1
        if total is not None:
            self.total = total
        now = time.perf_counter()
        tty = getattr(self.stream, "isatty", lambda: False)()
        # a terminal: the line rewritten twice a second; a log: a line per 10 s at most
        if not self.enabled or (now - self._last < (0.5 if tty else 10.0) and not force):
            return
        self._last = now
        el = now - self.t0
        eta = el / self.done * max(0, self.total - self.done) if self.done else float("nan")
        bad = ", ".join(f"{n} {s}" for s, n in sorted(self.bad.items())) or "0 failed"
        eta_s = "?" if eta != eta else (f"{eta / 60:.1f} min" if eta > 90 else f"{eta:.0f} s")
        self.stream.write(f"{chr(13) if tty else ''}sweep: {self.done}/{self.total} cases, {bad}, "
                          f"{el:.0f} s, ETA {eta_s}   {'' if tty else chr(10)}")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self.total:
            self.update(force=True)
            if getattr(self.stream, "isatty", lambda: False)():
                self.stream.write("\n")


def _row(spec: SweepSpec, case: Case, o: Outcome) -> dict[str, Any]:
    row: dict[str, Any] = {"case": case.index, "group": case.group, "hash": case.hash, "seed": case.seed,
                           "status": o.status, "survived": False, "wall_s": round(float(o.wall_s), 3),
                           "error": o.error}
    row.update(ordered_values(spec, case.values))
    row.update(o.metrics)
    row["survived"] = survived(row, spec.survive)
    return row


@dataclass(frozen=True)
class SweepRunOptions(Options):
    """How :func:`run_sweep` runs a spec's cases (None: the spec's setting)."""

    executor: str | Executor | None = None
    """``local`` | ``ray`` or an executor object (:class:`wbc.sweep.executor.Executor`, left open
    for the caller to reuse); None: the spec's"""
    workers: int | None = None
    """processes or Ray CPUs; None: the spec's"""
    address: str | None = None
    """the Ray cluster's address; None: the spec's"""
    timeout: float | None = None
    """wall time per case, s; None: the spec's"""
    out_dir: str | Path | None = None
    """folder of ``results.csv``; None: the spec's ``output``"""
    retry: bool = False
    """run again the cases stored as error, failed or timeout"""
    stop_after: int | None = None
    """stop once that many cases have finished in this call (the next call finishes the rest)"""
    progress: bool = True
    """print the progress line to stderr"""


def run_sweep(spec: SweepSpec, options: SweepRunOptions | None = None, /, **settings) -> SweepResult:
    """Run the cases of ``spec`` that the results store does not hold yet (module docstring).

    Args:
        spec: the sweep (:func:`wbc.sweep.spec.load_spec`).
        options: how to run it, :class:`SweepRunOptions` (None: its defaults).
        **settings: its fields one by one (``executor``, ``workers``, ``address``, ``timeout``
            in s, ``out_dir``, ``retry``, ``stop_after``, ``progress``), over ``options``.
    """
    how = SweepRunOptions.of(options, settings, "run_sweep")
    executor, workers, address, timeout, out_dir = how.executor, how.workers, how.address, how.timeout, how.out_dir
    retry, stop_after, progress = how.retry, how.stop_after, how.progress
    t0 = time.perf_counter()
    out = Path(out_dir) if out_dir is not None else spec.output
    store = ResultStore(out / "results.csv")
    kind = executor or spec.executor["type"]
    workers = workers or spec.executor.get("workers")
    res = SweepResult(spec, out, executor=kind if isinstance(kind, str) else getattr(kind, "name", type(kind).__name__))

    def stored(case: Case) -> dict | None:
        row = store.get(case.hash)
        return None if row is None or (retry and row.get("status") in RETRY) else row

    waiting: dict[str, list[int]] = {}        # hash -> bisection groups waiting for it
    todo: dict[str, Case] = {}
    cases: list[Case] = []
    axis = spec.bisect_axis
    if axis is None:
        cases = static_cases(spec)
        for c in cases:
            if stored(c) is None and c.hash not in todo:
                todo[c.hash] = c
        res.skipped = sum(stored(c) is not None for c in {c.hash: c for c in cases}.values())
    else:
        res.groups = [(g, Bisection(axis)) for g in grid_points(spec.grid_axes)]

    def advance(gi: int) -> None:
        """Replay group ``gi`` from the store until it needs a case that is not there."""
        g, b = res.groups[gi]
        assert axis is not None, "bisection groups exist only for a bisect axis"
        while not b.done:
            v = b.next_value()
            assert v is not None, "a search not done has a next value"
            case = make_case(spec, {**g, axis.key: v}, spec.seed, f"g{gi}.{len(b.probes)}", group=gi)
            row = stored(case)
            if row is None:
                waiting.setdefault(case.hash, []).append(gi)
                todo.setdefault(case.hash, case)
                return
            reused.add(case.hash)
            b.record(v, survived(row, spec.survive))

    reused: set[str] = set()                  # stored cases a bisection replayed
    for gi in range(len(res.groups)):
        advance(gi)
    if axis is not None:
        res.skipped = len(reused)

    def remaining() -> int:
        if axis is None:
            return len(todo)
        return sum(0 if b.done else max(1, max_probes(axis) - len(b.probes)) for _, b in res.groups)

    prog = Progress(remaining(), progress)
    ex = None
    try:
        if todo:
            ex = kind if not isinstance(kind, str) else make_executor(
                kind, workers=workers, timeout=timeout or spec.timeout, address=address or spec.executor.get("address"),
                runtime_env=spec.executor.get("runtime_env"))
            res.workers = ex.capacity
            submitted: dict[str, Case] = {}
            for h, c in list(todo.items()):
                ex.submit(Job(h, c.payload()))
                submitted[h] = c
            prog.update(force=True)
            while submitted:
                for o in ex.wait(0.5):
                    case = submitted.pop(o.job.key, None)
                    if case is None:                  # a job of an earlier, stopped sweep
                        continue
                    todo.pop(o.job.key, None)
                    row = _row(spec, case, o)
                    store.add(row)
                    res.ran += 1
                    for gi in waiting.pop(case.hash, []):
                        b = res.groups[gi][1]
                        v = b.next_value()
                        assert v is not None, "a search waiting for a case is not done"
                        b.record(v, row["survived"])
                        advance(gi)
                    for h, c in todo.items():
                        if h not in submitted:
                            ex.submit(Job(h, c.payload()))
                            submitted[h] = c
                    prog.update(o.status, total=prog.done + 1 + remaining())
                    if stop_after is not None and res.ran >= stop_after:
                        res.stopped = True
                        submitted.clear()
                        break
                prog.update()
    finally:
        if ex is not None and isinstance(kind, str):      # an executor object stays the caller's
            ex.close()
        prog.close()
    res.records = _records(spec, store, cases, res.groups)
    res.elapsed_s = time.perf_counter() - t0
    return res


def _records(spec: SweepSpec, store: ResultStore, cases: list[Case], groups) -> list[dict]:
    """One record per case of the spec that has a row: the case's own index and axis values
    (a row shared by cases of equal hash carries the first one's), ``survived`` re-judged."""
    if groups:
        axis = spec.bisect_axis
        assert axis is not None, "bisection groups exist only for a bisect axis"
        cases = [make_case(spec, {**g, axis.key: v}, spec.seed, f"g{gi}.{k}", group=gi)
                 for gi, (g, b) in enumerate(groups) for k, (v, _) in enumerate(b.probes)]
    out = []
    for c in cases:
        row = store.get(c.hash)
        if row is None:
            continue
        rec = {**row, "case": c.index, "group": c.group, **ordered_values(spec, c.values)}
        rec["survived"] = survived(rec, spec.survive)
        out.append(rec)
    return out
