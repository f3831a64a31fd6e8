"""A cycle's report (wbc.controller.solution.SolutionReport) as the Solution gives it back: every
field by name, ``conditions`` worked out from the status and the flags in their documented
order, an unknown field refused."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.controller.solution import Solution, SolutionReport

X = np.zeros(3)


def _sol(status: str, **report) -> Solution:
    return Solution(X, X, X, {}, X, status, "", SolutionReport(**report))


@pytest.mark.parametrize("status, flags, conditions", [
    ("ok", {}, ()),
    ("relaxed", {"relaxed": True}, ("relaxed",)),
    ("degraded", {}, ("degraded",)),                                    # the status alone says it
    ("saturated", {"relaxed": True, "degraded": True, "saturated": True}, ("relaxed", "degraded", "saturated")),
    ("saturated", {"saturated": True, "degraded": True}, ("degraded", "saturated")),
    ("failed", {"relaxed": True, "saturated": True}, ("failed",)),
    ("stopped", {"saturated": True}, ("stopped",)),
])
def test_conditions_follow_the_status_and_the_flags(status, flags, conditions):
    assert _sol(status, **flags).conditions == conditions


def test_the_report_fields_reach_the_solution():
    got = []
    sol = _sol("saturated", qp_count=2, saturated=True, tau_ratio=1.5, saturated_torques=[3], singular_levels=[1],
               evaluate=lambda: (got.append(1) or [0.5], {"t": 0.5}, ["d"]))
    assert (sol.qp_count, sol.saturated, sol.tau_ratio, sol.saturated_torques, sol.singular_levels) == \
        (2, True, 1.5, [3], [1])
    assert not got                                         # the diagnostics are worked out when read
    assert sol.residuals == [0.5] and sol.task_residuals == {"t": 0.5} and sol.diagnostics == ["d"]
    assert got == [1]
    bare = Solution(X, X, X, {}, X, "ok")
    assert (bare.qp_count, bare.relaxed, bare.saturated_torques, bare.singular_levels, bare.message) == (0, False, [], [], "")


def test_an_unknown_report_field_is_refused():
    with pytest.raises(TypeError, match="tau_max"):
        SolutionReport(tau_max=1.0)  # type: ignore[call-arg]


def _attributes(sol: Solution) -> dict:
    """Every attribute the Solution holds, arrays as bytes (so that == compares values)."""
    return {k: (v.tobytes() if isinstance(v, np.ndarray) else v) for k, v in vars(sol).items()}


def test_the_one_step_constructors_set_what_init_sets():
    """``Solution.of_cycle`` (the torque cycle's) and ``Solution.ok_without_qp`` (the velocity cycle's)
    set their attributes from one dict display instead of ``__init__``: the same names and values,
    so an attribute added to ``__init__`` and not to them fails here."""
    qdd, tau, tau_full, x = np.arange(3.0), np.ones(2), np.r_[0.0, 1.0, 1.0], np.arange(5.0)
    forces = {"left": np.ones(6)}

    def evaluate():
        return [], {}, []

    report = (2, True, True, True, 1.5, [1, 2], [0])
    made = Solution.of_cycle((qdd, tau, tau_full, forces, x), "saturated", "note", report, evaluate)
    ref = Solution(qdd, tau, tau_full, forces, x, "saturated", "note",
                   SolutionReport(*report, evaluate=evaluate))
    assert _attributes(made) == _attributes(ref)
    zeros = (np.zeros(3), np.zeros(2), np.zeros(3))
    made = Solution.ok_without_qp(zeros, x, evaluate)
    ref = Solution(*zeros, {}, x, "ok", "", SolutionReport(evaluate=evaluate))
    assert _attributes(made) == _attributes(ref)
