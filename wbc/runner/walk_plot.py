"""The walking panels of ``wbc run --plot`` (a run with a ``walk:`` section): the CoM, the
ZMP and the DCM in x and in y against their references, over the footstep timeline.

From ``series["walk"]`` (:meth:`wbc.runner.walking.WalkObserver.series`):

- x (m) and y (m) against time: the measured CoM, the ZMP from the simulator's contact forces
  and the measured DCM ξ = c + ċ/ω (solid), the CoM task's reference, the plan's ZMP reference
  and the reference's DCM (dashed), one colour per quantity;
- the footstep timeline: per foot, a bar over each swing (its actual lift-off to its
  touch-down), the planned single supports as thin outlines, the double supports the gaps.
"""

from __future__ import annotations

import numpy as np

_COLOURS = {"com": "tab:blue", "zmp": "tab:red", "dcm": "tab:green"}


def _xy(walk: dict, key: str) -> np.ndarray:
    a = np.array([[np.nan, np.nan] if v is None else v for v in walk.get(key, [])], dtype=float)
    return a.reshape(-1, 2)


def draw_walk(fig, cell, walk: dict) -> None:
    """Draw the module docstring's three panels into ``cell`` (a gridspec cell of ``fig``)."""
    sub = cell.subgridspec(3, 1, hspace=0.5, height_ratios=[1.0, 1.0, 0.45])
    t = np.asarray(walk.get("t", []), dtype=float)
    ax_x = fig.add_subplot(sub[0])
    ax_y = fig.add_subplot(sub[1], sharex=ax_x)
    ax_s = fig.add_subplot(sub[2], sharex=ax_x)
    for axis, ax in ((0, ax_x), (1, ax_y)):
        for q in ("com", "zmp", "dcm"):
            meas, ref = _xy(walk, q), _xy(walk, f"{q}_ref")
            if len(meas) == len(t) and len(t):
                ax.plot(t, meas[:, axis], color=_COLOURS[q], lw=1.1, label=f"{q.upper()}")
            if len(ref) == len(t) and len(t):
                ax.plot(t, ref[:, axis], color=_COLOURS[q], lw=1.0, ls="--", label=f"{q.upper()} reference")
        ax.set_ylabel(f"{'xy'[axis]} (m)")
        ax.set_title(f"walk: CoM, ZMP and DCM along {'xy'[axis]} (solid measured, dashed reference)",
                     fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    ax_x.legend(loc="upper left", fontsize=6, ncol=3, framealpha=0.7)
    rows = {"left": 1.0, "right": 0.0}
    for step in walk.get("footsteps", []):
        if step.get("lift") is not None and step["side"] in rows:
            ax_s.broken_barh([(step["lift"], step["land"] - step["lift"])], (rows[step["side"]] - 0.35, 0.7),
                             facecolors="none", edgecolors="0.5", lw=0.6)
    lifts = sorted(walk.get("lifts", []), key=lambda e: e["time"])
    downs = sorted(walk.get("touchdowns", []), key=lambda e: e["time"])
    end = float(t[-1]) if len(t) else 0.0
    for lift in lifts:
        land = next((d["time"] for d in downs if d["side"] == lift["side"] and d["time"] >= lift["time"]), end)
        if lift["side"] in rows:
            ax_s.broken_barh([(lift["time"], land - lift["time"])], (rows[lift["side"]] - 0.3, 0.6),
                             facecolors="tab:orange" if lift["side"] == "left" else "tab:purple", alpha=0.8)
    if len(t):
        ax_s.set_xlim(float(t[0]), end)      # the plan may go on after the run
    ax_s.set_yticks([0.0, 1.0], ["right", "left"], fontsize=7)
    ax_s.set_ylim(-0.6, 1.6)
    ax_s.set_title("footsteps: swings (filled: measured lift-off to touch-down; outline: planned)", fontsize=9,
                   loc="left")
    ax_s.set_xlabel("time (s)")
    ax_s.grid(alpha=0.3, axis="x")
    ax_s.tick_params(labelsize=7)
