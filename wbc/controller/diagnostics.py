"""Per-level residuals and diagnostics of one cycle, from the row values it produced (shared by
the torque cycle, :mod:`wbc.controller.cycle`, and the velocity one, :mod:`wbc.controller.velocity`)."""

from __future__ import annotations

from functools import partial

import numpy as np

from wbc.controller.singular import at_most, singular_directions
from wbc.controller.solution import LevelDiagnostics
from wbc.problem.buffer import split_values

#: an inequality row within this of a bound is reported active (units of the row)
ACTIVE_TOL = 1e-7


def level_diagnostics(levels, spans, infos, values, unenforced: tuple[bool, tuple[str, ...]],
                 sacrifice: tuple[float, float], saturated_torques: list | None = None,
                 singular: tuple | None = None):
    """Residuals per level and per task, and :class:`LevelDiagnostics`, from the row values
    of one cycle (``values`` = (:func:`~wbc.stack.row_values`' array, equality rows,
    inequality rows): A x − b, C x, l, u and b over every level, level k's part
    given by ``spans[k]``; see :meth:`Controller._finish`). ``unenforced``: (the solver did
    not enforce the general inequality rows, the tasks whose rows it met outside its
    cascade), from its SolveResult. The projection solver enforces
    equalities and joint-limit boxes in q̈; its friction cones are met (or relaxed) in
    force distribution and its torque limits are not enforced (the controller saturates
    τ): those rows are reported apart (``unenforced_violation``), not as residuals; the
    floating-base dynamics its forces meet are left out (its ``dynamics_gap`` and level 0's
    relaxation report them). ``sacrifice``: (absolute, relative) parts of the threshold.
    ``saturated_torques``: the joints the controller clipped at ±τ_max, reported by the
    level holding the torque limits (level 0 if the stack has none) as
    ``saturated_torques`` and ``active["torque_saturation"]``. A regularisation task
    (``Task.regularizer``) is never reported as sacrificed: its rows are not meant to be met.
    ``singular``: (the velocity names, a test σ → σ < ε) naming a damped level's singular
    directions and joints (:func:`~wbc.controller.singular.singular_directions`)."""
    residuals: list[float] = []
    task_res: dict[str, float] = {}
    diags: list[LevelDiagnostics] = []
    projection, outside = unenforced
    joint_names, threshold_of = singular if singular is not None else (None, None)
    sacrifice_tol, sacrifice_rel = sacrifice
    E, Y, LO, HI, B = split_values(*values)
    sat_level = -1
    if saturated_torques:
        sat_level = next((k for k, lvl in enumerate(levels) if "torque_limits" in lvl.kinds), 0)
    for lvl, (e0, e1, i0, n_gen, i1), info in zip(levels, spans, infos):
        index, names, eq_slices, in_slices, has_box = lvl.index, lvl.names, lvl.eq_slices, lvl.in_slices, lvl.box is not None
        e, b = E[e0:e1], B[e0:e1]
        if outside and any(n in outside for n in names):
            names = [n for n in names if n not in outside]
            e = e.copy()
            for n in outside:
                if n in eq_slices:
                    e[eq_slices[n]] = 0.0
        y, lo, hi = Y[i0:i1], LO[i0:i1], HI[i0:i1]
        with np.errstate(invalid="ignore"):          # a failed cycle's values are inf
            viol = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
            act = (np.abs(y - lo) < ACTIVE_TOL) | (np.abs(y - hi) < ACTIVE_TOL)
        unenforced_norm = 0.0
        if projection and n_gen:
            unenforced_norm = float(np.linalg.norm(viol[:n_gen]))
            viol[:n_gen] = 0.0
        residuals.append(float(np.sqrt(e @ e + viol @ viol)))
        sacrificed: list[str] = []
        active: dict[str, int] = {}
        violations: dict[str, list] = {}
        for name in names:
            r2 = 0.0
            tol = sacrifice_tol
            sl = eq_slices.get(name)
            if sl is not None:
                es = e[sl]
                r2 += float(es @ es)
                if sacrifice_rel:
                    tol += sacrifice_rel * float(np.linalg.norm(b[sl]))
            isl = in_slices.get(name)
            if isl is not None:
                vs = viol[isl]
                r2 += float(vs @ vs)
                n_act = int(np.count_nonzero(act[isl]))
                if n_act:
                    active[name] = n_act
                _violated_rows(violations, name, vs, np.arange(len(vs)), sacrifice_tol)
            r = r2**0.5
            task_res[name] = r
            if r > tol and name not in lvl.regularizers:
                sacrificed.append(name)
        if has_box:
            n_act = int(np.count_nonzero(act[n_gen:]))
            if n_act:
                active["joint_limits"] = n_act
            _violated_rows(violations, "joint_limits", viol[n_gen:], lvl.box[0], sacrifice_tol)
        sat = list(saturated_torques) if saturated_torques and len(diags) == sat_level else []
        if sat:
            active["torque_saturation"] = len(sat)
        is_singular = info.damping > 0.0 or info.singular
        sdirs: list[str] = []
        sjoints: list[str] = []
        if is_singular and joint_names is not None:
            sat_above = tuple(j for inf in infos[:len(diags) + 1] for j in inf.saturated)
            smin = info.sigma()
            below = threshold_of or partial(at_most, smin * (1 + 1e-9))
            sdirs, sjoints = singular_directions(levels, len(diags), len(joint_names), below, joint_names, sat_above)
        diags.append(LevelDiagnostics(
            singular=is_singular, singular_directions=sdirs, singular_joints=sjoints,
            index=index, tasks=list(names), residual=residuals[-1],
            rank=info.rank, sigma_min=info.sigma(), damping=info.damping,
            dof_before=info.dof_before, used_qp=info.used_qp, relaxed=info.relaxed,
            sacrificed=sacrificed, active=active, saturated_joints=list(info.saturated),
            unenforced_violation=unenforced_norm, qp_status=info.qp_status, saturated_torques=sat,
            violations=violations))
    return residuals, task_res, diags


def _violated_rows(out: dict, name: str, viol: np.ndarray, rows: np.ndarray, tol: float, keep: int = 8) -> None:
    """``out[name]`` = [(row, violation)] of the rows violated beyond ``tol``, worst first."""
    bad = np.flatnonzero((viol > tol) & np.isfinite(viol))      # a failed cycle's rows are inf
    if len(bad):
        bad = bad[np.argsort(-viol[bad], kind="stable")][:keep]
        out[name] = [(int(rows[i]), float(viol[i])) for i in bad]
