"""Per-level residuals and diagnostics of one cycle, from the row values it produced (shared by
the torque cycle, :mod:`wbc.controller.cycle`, and the velocity one, :mod:`wbc.controller.velocity`)."""

from __future__ import annotations

import numpy as np

from wbc.controller.solution import LevelDiagnostics
from wbc.problem.buffer import split_values


def level_diagnostics(levels, spans, infos, values, projection: bool, sacrifice_tol: float,
                 sacrifice_rel: float = 0.0, tol_act: float = 1e-7, saturated_torques: list | None = None):
    """Residuals per level and per task, and :class:`LevelDiagnostics`, from the row values
    of one cycle (``values`` = (:func:`~wbc.stack.row_values`' array, equality rows,
    inequality rows): A x − b, C x, l, u and b over every level, level k's part
    given by ``spans[k]``; see :meth:`Controller._finish`). The projection solver enforces
    equalities and joint-limit boxes in q̈; its friction cones are met (or relaxed) in
    force distribution and its torque limits are not enforced (the controller saturates
    τ): those rows are reported apart (``unenforced_violation``), not as residuals.
    ``saturated_torques``: the joints the controller clipped at ±τ_max, reported by the
    level holding the torque limits (level 0 if the stack has none) as
    ``saturated_torques`` and ``active["torque_saturation"]``. A regularisation task
    (``Task.regularizer``) is never reported as sacrificed: its rows are not meant to be met."""
    residuals: list[float] = []
    task_res: dict[str, float] = {}
    diags: list[LevelDiagnostics] = []
    E, Y, LO, HI, B = split_values(*values)
    sat_level = -1
    if saturated_torques:
        sat_level = next((k for k, lvl in enumerate(levels) if any(t.kind == "torque_limits" for t in lvl.tasks)), 0)
    for lvl, (e0, e1, i0, n_gen, i1), info in zip(levels, spans, infos):
        index, tasks, eq_slices, in_slices, has_box = lvl.index, lvl.tasks, lvl.eq_slices, lvl.in_slices, lvl.box is not None
        e, b = E[e0:e1], B[e0:e1]
        y, lo, hi = Y[i0:i1], LO[i0:i1], HI[i0:i1]
        with np.errstate(invalid="ignore"):          # a failed cycle's values are inf
            viol = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
            act = (np.abs(y - lo) < tol_act) | (np.abs(y - hi) < tol_act)
        unenforced = 0.0
        if projection and n_gen:
            unenforced = float(np.linalg.norm(viol[:n_gen]))
            viol[:n_gen] = 0.0
        residuals.append(float(np.sqrt(e @ e + viol @ viol)))
        sacrificed: list[str] = []
        active: dict[str, int] = {}
        violations: dict[str, list[tuple[int, float]]] = {}
        for t in tasks:
            r2 = 0.0
            tol = sacrifice_tol
            sl = eq_slices.get(t.name)
            if sl is not None:
                es = e[sl]
                r2 += float(es @ es)
                if sacrifice_rel:
                    tol += sacrifice_rel * float(np.linalg.norm(b[sl]))
            isl = in_slices.get(t.name)
            if isl is not None:
                vs = viol[isl]
                r2 += float(vs @ vs)
                n_act = int(np.count_nonzero(act[isl]))
                if n_act:
                    active[t.name] = n_act
                _violated_rows(violations, t.name, vs, np.arange(len(vs)), sacrifice_tol)
            r = r2**0.5
            task_res[t.name] = r
            if r > tol and not t.regularizer:
                sacrificed.append(t.name)
        if has_box:
            n_act = int(np.count_nonzero(act[n_gen:]))
            if n_act:
                active["joint_limits"] = n_act
            _violated_rows(violations, "joint_limits", viol[n_gen:], lvl.box[0], sacrifice_tol)
        sat = list(saturated_torques or []) if len(diags) == sat_level else []
        if sat:
            active["torque_saturation"] = len(sat)
        diags.append(LevelDiagnostics(
            index=index, tasks=[t.name for t in tasks], residual=residuals[-1],
            rank=info.rank, sigma_min=info.sigma(), damping=info.damping,
            dof_before=info.dof_before, used_qp=info.used_qp, relaxed=info.relaxed,
            sacrificed=sacrificed, active=active, saturated_joints=list(info.saturated),
            unenforced_violation=unenforced, qp_status=info.qp_status, saturated_torques=sat,
            violations=violations))
    return residuals, task_res, diags


def _violated_rows(out: dict, name: str, viol: np.ndarray, rows: np.ndarray, tol: float, keep: int = 8) -> None:
    """``out[name]`` = [(row, violation)] of the rows violated beyond ``tol``, worst first."""
    bad = np.flatnonzero((viol > tol) & np.isfinite(viol))      # a failed cycle's rows are inf
    if len(bad):
        bad = bad[np.argsort(-viol[bad], kind="stable")][:keep]
        out[name] = [(int(rows[i]), float(viol[i])) for i in bad]
