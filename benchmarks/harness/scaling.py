"""Scaling: cycle time against nv and against the number of levels, and its exponents.

The nv sweep drives serial chains built with pinocchio (nv 12 to 156) through a simple
4-level stack; the levels sweep splits the same ten Talos task groups over 1 to 10
levels. Each point is a :func:`.timing.run_case` without phases; the exponents are the
least-squares slopes of log(median) against log(nv) or log(levels), over every point and
over the upper half of the range (where the fixed per-cycle Python overhead weighs least).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from wbc.robot.model import RobotModel

from .report import num
from .stacks import chain_robot, chain_stack, talos_levels_stack
from .timing import run_case


def loglog_exponent(x, y) -> float:
    """Slope of log y against log x (least squares)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = (x > 0) & (y > 0) & np.isfinite(y)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])


def scaling(talos: RobotModel | None, nvs, levels, cycles: int, warmup: int,
            progress: Callable[[str], None] | None = None, budget_s: float | None = None) -> dict:
    """Median cycle time of hqp and projection (daqp) against nv (:func:`.stacks.chain_robot`
    with ``nvs`` joints, :func:`.stacks.chain_stack`, the tip on a circle) and against the
    number of levels (Talos, :func:`.stacks.talos_levels_stack` for each of ``levels``),
    with the log-log exponents (:func:`fit_exponents`)."""
    out: dict = {"cycles": cycles, "warmup": warmup, "solvers": ["hqp", "projection"],
                 "nv": {"stack": "chain: joint limits / tip position / mid position / posture",
                        "points": []},
                 "levels": {"stack": "talos: 10 task groups (limits+contacts, CoM, hands, torso, head, "
                                     "elbows, base, posture) over 1..10 levels", "points": []}}
    for n in nvs:
        robot = chain_robot(n)
        for solver in ("hqp", "projection"):
            c = run_case(robot, chain_stack, solver, "daqp", cycles, warmup, circles=("tip",), phases=False,
                         budget_s=budget_s)
            out["nv"]["points"].append(_point(c, nv=n))
            if progress:
                progress(f"  scaling nv={n:4d} {solver:10s} " + _point_text(c))
    if talos is not None:
        for L in levels:
            for solver in ("hqp", "projection"):
                c = run_case(talos, lambda L=L: talos_levels_stack(L), solver, "daqp", cycles, warmup, phases=False,
                             budget_s=budget_s)
                out["levels"]["points"].append(_point(c, levels=L))
                if progress:
                    progress(f"  scaling levels={L:2d} {solver:10s} " + _point_text(c))
    return fit_exponents(out)


def fit_exponents(sc: dict) -> dict:
    """Log-log exponents of the median cycle time: over every point (``nv_hqp`` ...) and
    over the upper half of the range (``nv_hqp_upper`` ...), where the fixed per-cycle
    Python overhead weighs least."""
    exps, ranges = {}, {}
    for axis in ("nv", "levels"):
        for solver in ("hqp", "projection"):
            pts = [p for p in sc[axis]["points"] if p["solver"] == solver and p["median_ms"] is not None]
            x = [p[axis] for p in pts]
            y = [p["median_ms"] for p in pts]
            exps[f"{axis}_{solver}"] = loglog_exponent(x, y)
            if x:
                cut = np.median(np.unique(x))
                up = [(a, b) for a, b in zip(x, y) if a >= cut]
                exps[f"{axis}_{solver}_upper"] = loglog_exponent([a for a, _ in up], [b for _, b in up])
                ranges[axis] = f"{axis} {min(a for a, _ in up):g}-{max(a for a, _ in up):g}"
    sc["exponents"] = {k: (None if not np.isfinite(e) else e) for k, e in exps.items()}   # None: too few points
    sc["upper_range"] = ranges
    return sc


def _point(c: dict, **key) -> dict:
    p = dict(key, solver=c["solver"])
    if "error" in c:
        p.update(median_ms=None, error=c["error"])
        return p
    p.update(median_ms=c["median_ms"], p99_ms=c["p99_ms"], max_ms=c["max_ms"], cycles=c["cycles"],
             qp_per_cycle=c["qp_per_cycle"], statuses=c["statuses"])
    if "truncated" in c:
        p["truncated"] = c["truncated"]
    return p


def _point_text(c: dict) -> str:
    if "error" in c:
        return "failed: " + c["error"]
    return (f"{c['median_ms']:8.3f} ms (p99 {c['p99_ms']:.3f}, {c['qp_per_cycle']:.1f} QP/cycle)"
            + (" TRUNCATED" if "truncated" in c else ""))


def plot_scaling(sc: dict, path: Path) -> None:
    """Both sweeps, median and p99 on log-log axes, to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, axis, xlabel in ((axes[0], "nv", "nv (serial chain)"), (axes[1], "levels", "levels (Talos, same tasks)")):
        xs = set()
        for solver, style, color in (("hqp", "o-", "C0"), ("projection", "s--", "C1")):
            pts = [p for p in sc[axis]["points"] if p["solver"] == solver and p["median_ms"] is not None]
            if not pts:
                continue
            x = np.array([p[axis] for p in pts], float)
            xs.update(x.tolist())
            e = sc["exponents"][f"{axis}_{solver}"]
            ax.plot(x, [p["median_ms"] for p in pts], style, color=color, label=f"{solver} median (exponent {num(e)})")
            ax.plot(x, [p["p99_ms"] for p in pts], ":", color=color, alpha=0.5, label=f"{solver} p99")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(sorted(xs))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(xlabel)
        ax.set_ylabel("cycle time (ms)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("cycle time vs nv")
    axes[1].set_title("cycle time vs number of levels")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=72)
    plt.close(fig)
