"""Plots of a sweep (matplotlib, PNG files beside ``results.csv``).

- ``push_polar.png``: for a push study, the axes ``X@direction_deg`` (deg) and
  ``X@magnitude`` (N): a bisection's largest survived magnitude per direction, one curve
  per group of the other axes (e.g. per solver); a grid's survived fraction as a heat map
  over direction × magnitude (``push_map.png``, one panel per group); random draws as a
  polar scatter, survived and not (``push_scatter.png``).
- ``histograms.png``: the distribution of each metric in ``plots.histograms`` (default
  ``tasks.com.rms`` in m, ``support_margin_min`` in m), one histogram per group, cases
  that ran to their end.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .engine import SweepResult
from .summary import groups


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _label(keys: list[str], values: tuple) -> str:
    return ", ".join(f"{k}={v}" for k, v in zip(keys, values)) or "all"


def _push_axes(res: SweepResult) -> tuple[str | None, str | None]:
    mag = next((a.key for a in res.spec.axes if a.key.endswith("@magnitude")), None)
    dirn = next((a.key for a in res.spec.axes if a.key.endswith("@direction_deg")), None)
    return mag, dirn


def plot_all(res: SweepResult) -> list[Path]:
    """Every plot that applies to ``res``; returns the files written."""
    out = []
    mag, dirn = _push_axes(res)
    if mag and dirn:
        a_mag = next(a for a in res.spec.axes if a.key == mag)
        a_dir = next(a for a in res.spec.axes if a.key == dirn)
        if res.groups and a_mag.kind == "bisect":
            out.append(polar_limits(res, mag, dirn))
        elif a_mag.kind == "values" and a_dir.kind == "values":
            out.append(heat_map(res, mag, dirn))
        elif res.records:
            out.append(polar_scatter(res, mag, dirn))
    h = histograms(res)
    if h is not None:
        out.append(h)
    return out


def polar_limits(res: SweepResult, mag: str, dirn: str) -> Path:
    """Largest survived magnitude per direction, one closed curve per other group."""
    plt = _plt()
    others = [a.key for a in res.spec.grid_axes if a.key != dirn]
    curves: dict[tuple, list[tuple[float, float, bool]]] = {}
    for g, b in res.groups:
        lim = b.limit if b.limit is not None else 0.0
        curves.setdefault(tuple(g[k] for k in others), []).append((float(g[dirn]), float(lim),
                                                                  b.outcome == "at_least_hi"))
    fig = plt.figure(figsize=(6.4, 6.0), dpi=110)
    ax = fig.add_subplot(projection="polar")
    for key, pts in curves.items():
        pts.sort()
        th = np.radians([p[0] for p in pts] + [pts[0][0]])
        r = [p[1] for p in pts] + [pts[0][1]]
        line, = ax.plot(th, r, "o-", label=_label(others, key))
        capped = [(math.radians(p[0]), p[1]) for p in pts if p[2]]
        if capped:
            ax.plot(*zip(*capped), "^", color=line.get_color(), ms=9)
    ax.set_title(f"largest survived {mag.split('@')[0]} magnitude (N) per direction (deg)\n"
                 "(^: the upper bound survived)", fontsize=9)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.12, -0.12), fontsize=8)
    path = res.out_dir / "push_polar.png"
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return path


def heat_map(res: SweepResult, mag: str, dirn: str) -> Path:
    """Survived fraction over direction × magnitude, one panel per group of the other axes."""
    plt = _plt()
    a_mag = next(a for a in res.spec.axes if a.key == mag)
    a_dir = next(a for a in res.spec.axes if a.key == dirn)
    others = [a.key for a in res.spec.axes if a.key not in (mag, dirn) and a.kind in ("values", "choices")]
    panels = groups(res.records, others)
    fig, axes = plt.subplots(1, max(1, len(panels)), figsize=(4.5 * max(1, len(panels)), 4.2), dpi=110,
                             squeeze=False)
    mags, dirs = list(a_mag.values), list(a_dir.values)
    for ax, (key, rs) in zip(axes[0], panels.items()):
        k, n = np.zeros((len(dirs), len(mags))), np.zeros((len(dirs), len(mags)))
        for r in rs:
            i, j = dirs.index(r[dirn]), mags.index(r[mag])
            n[i, j] += 1
            k[i, j] += bool(r.get("survived"))
        with np.errstate(invalid="ignore"):
            im = ax.imshow(k / n, origin="lower", aspect="auto", vmin=0, vmax=1, cmap="RdYlGn")
        ax.set_xticks(range(len(mags)), [f"{m:g}" for m in mags], rotation=90, fontsize=7)
        ax.set_yticks(range(len(dirs)), [f"{d:g}" for d in dirs], fontsize=7)
        ax.set_xlabel("push magnitude (N)")
        ax.set_ylabel("push direction (deg)")
        ax.set_title(_label(others, key), fontsize=9)
    fig.colorbar(im, ax=axes[0].tolist(), label="survived fraction")
    path = res.out_dir / "push_map.png"
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return path


def polar_scatter(res: SweepResult, mag: str, dirn: str) -> Path:
    """Each case at (direction, magnitude): survived (green) or not (red), per group."""
    plt = _plt()
    keys = [k for k in res.spec.group_by if k not in (mag, dirn)]
    panels = groups(res.records, keys)
    fig = plt.figure(figsize=(4.5 * max(1, len(panels)), 4.5), dpi=110)
    for p, (key, rs) in enumerate(panels.items()):
        ax = fig.add_subplot(1, len(panels), p + 1, projection="polar")
        for ok, color in ((True, "tab:green"), (False, "tab:red")):
            pts = [(math.radians(r[dirn]), r[mag]) for r in rs if bool(r.get("survived")) == ok]
            if pts:
                ax.scatter(*zip(*pts), s=8, color=color, label="survived" if ok else "not")
        ax.set_title(_label(keys, key), fontsize=9)
    fig.axes[0].legend(loc="lower left", fontsize=7)
    path = res.out_dir / "push_scatter.png"
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return path


def histograms(res: SweepResult) -> Path | None:
    """Histograms of the metrics in ``plots.histograms`` (module docstring), or None."""
    ran = [r for r in res.records if r.get("status") in ("ok", "fell")]
    metrics = [m for m in res.spec.histograms
               if sum(isinstance(r.get(m), (int, float)) and not isinstance(r.get(m), bool) for r in ran) >= 2]
    if not metrics or res.groups:
        return None
    plt = _plt()
    keys = res.spec.group_by
    panels = groups(ran, keys)
    fig, axes = plt.subplots(1, len(metrics), figsize=(5 * len(metrics), 3.6), dpi=110, squeeze=False)
    for ax, m in zip(axes[0], metrics):
        allv = np.array([r[m] for r in ran if isinstance(r.get(m), (int, float))], float)
        allv = allv[np.isfinite(allv)]
        if allv.size == 0:
            continue
        bins = np.linspace(allv.min(), allv.max() if allv.max() > allv.min() else allv.min() + 1e-9, 30)
        for key, rs in panels.items():
            v = np.array([r[m] for r in rs if isinstance(r.get(m), (int, float))], float)
            ax.hist(v[np.isfinite(v)], bins=bins, alpha=0.55, label=_label(keys, key))
        ax.set_xlabel(m)
        ax.set_ylabel("cases")
        ax.legend(fontsize=7)
    path = res.out_dir / "histograms.png"
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
