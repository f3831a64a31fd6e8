"""Plots of a run's time series (``wbc run --plot`` and ``wbc plot metrics.json``).

One figure, 1200 × 800 px by default:

- left column, one panel per priority level: the norm of each task's error over
  time (m for positions, rad for orientations and postures, N for forces); a level
  without task errors (level 0: dynamics, contacts, limits) shows its residual
  ‖A x − b‖ on a log scale. Each title gives the level's rank and smallest σ of J̄_k.
- right column: contact normal forces F_n per contact (N, with m g for reference);
  friction margins μ F_n − ‖F_t‖ of each contact's resultant force (N, ≥ 0 inside
  the friction cone); joint torques against their limits: the largest |τ_i|/τ_max,i
  per cycle and the traces of the joints that came closest.
- a walking run (``series["walk"]``): below, the CoM, ZMP and DCM in x and y against their
  references and the footstep timeline (:mod:`wbc.runner.walk_plot`), the figure 1.75 × taller.

The series come from :func:`wbc.runner.loop.run` with ``series=True`` (``metrics["series"]``).
matplotlib runs on its Agg back-end (no display needed).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from wbc.errors import PlotError


def _arr(x) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in x], dtype=float)


def _level_title(k: int, names: list[str], rank: np.ndarray, sigma: np.ndarray) -> str:
    label = ", ".join(names) if len(names) <= 3 else ", ".join(names[:3]) + ", …"
    ok = np.isfinite(rank)
    if not ok.any():
        return f"level {k}: {label}"
    lo, hi = int(np.nanmin(rank)), int(np.nanmax(rank))
    return f"level {k}: {label}   rank {lo if lo == hi else f'{lo}–{hi}'}, min σ(J̄) {np.nanmin(sigma):.2g}"


def plot_series(series: dict, out: str | Path, title: str = "", size: tuple[float, float] = (12.0, 8.0),
                dpi: int = 100) -> Path:
    """Draw ``series`` (a :meth:`wbc.runner.loop.Series.to_dict`) into the PNG ``out``;
    ``size`` in inches at ``dpi`` (default 1200 × 800 px). Returns the path."""
    try:
        import matplotlib
    except ImportError:
        raise PlotError("plots need matplotlib (a dependency of wbc): pip install matplotlib") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = _arr(series["t"])
    if len(t) == 0:
        raise PlotError("the time series is empty (a run of zero cycles)")
    levels = series["levels"]
    task_errors = {k: _arr(v) for k, v in series.get("task_errors", {}).items()}
    task_level = series.get("task_level", {})
    tl = _arr(series.get("level_t", series["t"]))     # diagnostics are sampled every few cycles
    res = [_arr(r) for r in series["level_residual"]]
    rank = [_arr(r) for r in series["level_rank"]]
    sig = [_arr(r) for r in series["level_sigma_min"]]
    nlev = max(len(levels), len(res))

    walk = series.get("walk")
    if walk:        # a walking run: its panels (wbc.runner.walk_plot) below, the figure taller
        fig = plt.figure(figsize=(size[0], size[1] * 1.75), dpi=dpi)
        outer = fig.add_gridspec(2, 1, left=0.07, right=0.98, top=0.96 if title else 0.98, bottom=0.04,
                                 height_ratios=[1.0, 0.75], hspace=0.12)
        gs = outer[0].subgridspec(1, 2, wspace=0.22)
    else:
        fig = plt.figure(figsize=size, dpi=dpi)
        gs = fig.add_gridspec(1, 2, left=0.07, right=0.98, top=0.93 if title else 0.96, bottom=0.07,  # type: ignore[assignment]  # a GridSpec indexes as the sub-gridspec does
                              wspace=0.22)
    left = gs[0].subgridspec(nlev, 1, hspace=0.55)
    right = gs[1].subgridspec(3, 1, hspace=0.45)
    cmap = plt.get_cmap("tab10")

    for k in range(nlev):
        ax = fig.add_subplot(left[k])
        names = levels[k] if k < len(levels) else []
        mine = [n for n, lv in task_level.items() if lv == k and n in task_errors]
        if mine:
            for j, n in enumerate(mine):
                ax.plot(t, task_errors[n], color=cmap(j), lw=1.2, label=n)
            ax.set_ylabel("‖e‖ (m | rad)")
            ax.legend(loc="upper right", fontsize=7, frameon=False)
        elif k < len(res):
            if np.nanmax(res[k], initial=0.0) > 0.0:
                ax.semilogy(tl, np.maximum(res[k], 1e-16), color="0.3", lw=1.0, label="level residual")
            else:
                ax.plot(tl, np.nan_to_num(res[k]), color="0.3", lw=1.0, label="level residual (exactly 0)")
            ax.set_ylabel("‖Ax − b‖")
            ax.legend(loc="upper right", fontsize=7, frameon=False)
        rk = rank[k] if k < len(rank) else np.array([np.nan])
        sg = sig[k] if k < len(sig) else np.array([np.nan])
        ax.set_title(_level_title(k, names, rk, sg), fontsize=8, loc="left")
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        if k == nlev - 1:
            ax.set_xlabel("time (s)")

    contacts = series.get("contacts", {})
    ax_f = fig.add_subplot(right[0])
    ax_m = fig.add_subplot(right[1], sharex=ax_f)
    total = np.zeros_like(t)
    for j, (c, d) in enumerate(contacts.items()):
        fn = _arr(d["normal_force"])
        total += np.nan_to_num(fn)
        ax_f.plot(t, fn, color=cmap(j), lw=1.2, label=c)
        ax_m.plot(t, _arr(d["friction_margin"]), color=cmap(j), lw=1.2, label=c)
    if contacts:
        ax_f.plot(t, total, color="k", lw=0.8, ls=":", label="sum")
        if "mass" in series and "g" in series:       # the robot's weight, with the model's gravity
            mg = series["mass"] * series["g"]
            ax_f.axhline(mg, color="0.5", lw=0.8, ls="--", label=f"m g = {mg:.0f} N")
    ax_f.set_title("contact normal forces F_n", fontsize=9, loc="left")
    ax_f.set_ylabel("N")
    ax_m.axhline(0.0, color="r", lw=0.8)
    ax_m.set_title(f"friction margin μ F_n − ‖F_t‖ (μ = {series.get('mu', float('nan')):.2g}; < 0: sliding)",
                   fontsize=9, loc="left")
    ax_m.set_ylabel("N")

    ax_t = fig.add_subplot(right[2], sharex=ax_f)
    torque = series.get("torque", {})
    if torque.get("ratio_max"):
        ax_t.plot(t, _arr(torque["ratio_max"]), color="k", lw=1.4, label="max over joints")
        for j, (name, trace) in enumerate(torque.get("joints", {}).items()):
            ax_t.plot(t, _arr(trace), color=cmap(j), lw=0.8, alpha=0.8,
                      label=f"{name} (τ_max {torque['limits'][name]:.0f})")
    ax_t.axhline(1.0, color="r", lw=0.8, ls="--", label="limit")
    ax_t.set_ylim(0.0, max(1.05, float(np.nanmax(_arr(torque.get("ratio_max", [0.0])), initial=0.0)) * 1.05))
    ax_t.set_title("joint torques against their limits |τ_i| / τ_max,i", fontsize=9, loc="left")
    ax_t.set_xlabel("time (s)")
    if not contacts:
        for ax in (ax_f, ax_m):
            ax.text(0.5, 0.5, "no contacts in this scenario", transform=ax.transAxes, ha="center", va="center",
                    color="0.4")
    for ax in (ax_f, ax_m, ax_t):
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="best", fontsize=6, framealpha=0.7, ncol=2)
    if walk:
        from wbc.runner.walk_plot import draw_walk
        draw_walk(fig, outer[1], walk)
    if title:
        fig.suptitle(title, fontsize=11)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def plot_metrics(metrics: dict, out: str | Path, **kwargs) -> Path:
    """Plot a metrics dict (from :func:`wbc.runner.loop.run` with ``series=True``)."""
    if "series" not in metrics:
        raise PlotError("these metrics carry no time series: run with "
                        "`wbc run FILE --headless --plot out.png` or `--series --metrics m.json`")
    title = (f"{metrics.get('scenario', '')}  ({metrics.get('robot', '')}, solver {metrics.get('solver', '')}, "
             f"{metrics.get('duration', 0.0):.2f} s{', FELL' if metrics.get('fell') else ''})")
    return plot_series(metrics["series"], out, title=title, **kwargs)


def plot_file(path: str | Path, out: str | Path, **kwargs) -> Path:
    """Plot a metrics JSON file written by ``wbc run --series --metrics`` (or ``--plot``)."""
    path = Path(path)
    try:
        metrics = json.loads(path.read_text())
    except FileNotFoundError:
        raise PlotError(f"{path}: no such file") from None
    except json.JSONDecodeError as exc:
        raise PlotError(f"{path}: not JSON ({exc})") from None
    if not isinstance(metrics, dict) or "series" not in metrics:
        raise PlotError(f"{path}: no time series in this metrics file: write one with "
                        "`wbc run FILE --headless --series --metrics {path}` (or `--plot out.png`)")
    return plot_metrics(metrics, out, **kwargs)
