"""Random edit sequences on a running controller: Talos standing (tests.helpers.stacks.talos_stack: limits,
torque limits, two sole contacts / CoM / both hands / posture), then add, remove, move and retarget
frame, CoM and posture tasks, release and make contacts (force ramps of 2-10 cycles),
push the robot and switch solver (hqp, projection, weighted: a new Controller on the same
stack, when no force ramp is under way, since the ramps live in the controller), 2 control
cycles after each edit with the state integrated from the controller's own q̈. After every cycle:

- τ finite and within ±τ_max; τ = clip(S_a(M q̈ + h − J_fᵀ f)) and the root rows of
  M q̈ + h = Sᵀτ + J_fᵀ f (5.26) hold to 1e-8 (relative to max(1, |M q̈ + h|, |h|)), unless
  the projection solver reports that q̈ needs forces outside the cones (``relaxed``);
- a released contact leaves the stack when its ramp ends; a touched-down one ends at fmax = ∞.

After every edit, strict priority: each level's residual ‖A x − b‖ equals the one of the
stack cut below it (the prefix solved alone: :mod:`tests.solvers.test_priority`'s comparison, same
tolerance); for the weighted solver, only level 0 is strict.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule, run_state_machine_as_test

import wbc
from tests.helpers.stacks import randomise_targets, talos_stack
from wbc.controller.cycle import SOLVERS
from wbc.tasks import CoM, Contact, Frame, Posture

DT, CYCLES, FEET = 1e-3, 2, ("left_foot", "right_foot")
FRAMES = ("left_hand", "right_hand", "torso", "head", "left_foot", "right_foot")
MASKS = ("pose", "position", "orientation")
PRIORITY_TOL, DYNAMICS_TOL = 1e-6, 1e-8
COUNTS = {"sequences": 0, "steps": 0, "cycles": 0, "priority_checks": 0, "relaxed": 0}


@cache
def talos() -> wbc.RobotModel:
    return wbc.load_robot("talos")


def _retarget(task, robot, seed) -> None:
    """A target near the task's current value (tests.helpers.stacks.randomise_targets; robot.update done)."""
    randomise_targets(wbc.Stack([[task]]), robot, np.random.default_rng(seed))


class Standing(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.robot = robot = talos()
        self.stack = talos_stack()
        self.q, self.v, self.k, self.ramps, self.sol = robot.q_default.copy(), np.zeros(robot.nv), 0, {}, None
        COUNTS["sequences"] += 1

    @initialize(solver=st.sampled_from(SOLVERS))
    def start(self, solver):
        self.ctrl = wbc.Controller(self.robot, self.stack, solver=solver, dt=DT)
        self._cycles()

    # ------------------------------------------------------------------ edits
    def _motion(self):
        return [t.name for t in self.stack if t.kind in ("com", "frame", "posture")]

    def _stable_contacts(self):
        return [c.name for c in self.stack.contacts() if c.name not in self.ramps]

    @rule(kind=st.sampled_from(["com", "posture", "frame"]), frame=st.sampled_from(FRAMES),
          mask=st.sampled_from(MASKS), level=st.integers(1, 6), kp=st.floats(5.0, 200.0), seed=st.integers(0, 2**32 - 1))
    def add(self, kind, frame, mask, level, kp, seed):
        name = f"{kind}_{self.k}"
        task = {"com": lambda: CoM(kp=kp, name=name), "posture": lambda: Posture(kp=kp, name=name),
                "frame": lambda: Frame(frame, kp=kp, name=name, mask=mask)}[kind]()
        task.bind(self.robot)
        self.robot.update(self.q, self.v)
        _retarget(task, self.robot, seed)
        self.stack.add(task, min(level, len(self.stack.levels)))
        self._cycles()

    @precondition(lambda self: self._motion())
    @rule(data=st.data())
    def remove(self, data):
        self.stack.remove(data.draw(st.sampled_from(self._motion())))
        self._cycles()

    @precondition(lambda self: self._motion())
    @rule(data=st.data(), level=st.integers(1, 6))
    def move(self, data, level):
        self.stack.move(data.draw(st.sampled_from(self._motion())), level)
        self._cycles()

    @precondition(lambda self: self._motion())
    @rule(data=st.data(), seed=st.integers(0, 2**32 - 1))
    def retarget(self, data, seed):
        task = self.stack[data.draw(st.sampled_from(self._motion()))]
        self.robot.update(self.q, self.v)
        _retarget(task, self.robot, seed)
        self._cycles()

    @precondition(lambda self: len(self._stable_contacts()) >= 2)
    @rule(data=st.data(), cycles=st.integers(2, 10))
    def release(self, data, cycles):
        name = data.draw(st.sampled_from(self._stable_contacts()))
        self.ctrl.release_contact(name, duration=cycles * DT)
        self.ramps[name] = (self.k + cycles, "release")
        self._cycles()

    @precondition(lambda self: len(self.stack.contacts()) < 2)
    @rule(cycles=st.integers(2, 10))
    def touchdown(self, cycles):
        foot = next(f for f in FEET if f not in {c.contact for c in self.stack.contacts()})
        self.robot.update(self.q, self.v)
        task = Contact(foot, name=f"{foot}_{self.k}")
        self.ctrl.make_contact(task, level=0, duration=cycles * DT)
        self.ramps[task.name] = (self.k + cycles, "touchdown")
        self._cycles()

    @rule(seed=st.integers(0, 2**32 - 1))
    def push(self, seed):
        self.v = self.v + 0.2 * np.random.default_rng(seed).standard_normal(self.robot.nv)
        self._cycles()

    @precondition(lambda self: not self.ramps)      # a new controller starts with no force ramp
    @rule(solver=st.sampled_from(SOLVERS))
    def switch_solver(self, solver):
        self.ctrl = wbc.Controller(self.robot, self.stack, solver=solver, dt=DT)
        self._cycles()

    # ----------------------------------------------------------- invariants
    def _cycles(self) -> None:
        COUNTS["steps"] += 1
        for _ in range(CYCLES):
            sol = self.ctrl.solve(self.q, self.v)
            self.k += 1
            self._check_dynamics(sol)
            self._check_ramps()
            self.sol, self.state = sol, (self.q, self.v)
            self.v = self.v + DT * sol.qdd
            self.q = pin.integrate(self.robot.model, self.q, DT * self.v)
        self.residuals = list(self.sol.residuals)       # before another controller refills the rows

    def _check_dynamics(self, sol) -> None:
        robot, a, u = self.robot, self.robot.actuated_idx, self.robot.unactuated_idx
        COUNTS["cycles"] += 1
        assert sol.ok, sol.message
        assert np.all(np.isfinite(sol.tau)), "non-finite τ"
        assert np.all(np.abs(sol.tau) <= robot.tau_max[a]), f"|τ| up to {np.max(np.abs(sol.tau) / robot.tau_max[a]):.3g} τ_max"
        Jf = self.ctrl.layout.force_jacobian
        lhs = robot.M @ sol.qdd + robot.h
        gen = lhs - (Jf.T @ sol.x[robot.nv:] if Jf is not None else 0.0)
        scale = max(1.0, np.abs(lhs).max(), np.abs(robot.h).max())
        lim = robot.tau_max[a]
        np.testing.assert_allclose(sol.tau, np.clip(gen[a], -lim, lim), rtol=0, atol=DYNAMICS_TOL * scale)
        if sol.relaxed and self.ctrl.solver_name == "projection":
            assert "cones" in sol.message, sol.message
            COUNTS["relaxed"] += 1
            return
        assert np.abs(gen[u]).max() <= DYNAMICS_TOL * scale, f"root dynamics off by {np.abs(gen[u]).max():.3g}"

    def _check_ramps(self) -> None:
        for name, (end, kind) in list(self.ramps.items()):
            if self.k >= end:
                del self.ramps[name]
                if kind == "release":
                    assert name not in self.stack, f"{name} still in the stack after its release ramp"
                else:
                    assert self.stack[name].fmax == np.inf

    @invariant()
    def strict_priority(self) -> None:
        levels = self.stack.levels
        strict = range(1, len(levels)) if self.ctrl.solver_name != "weighted" else range(1, min(2, len(levels)))
        q, v = self.state
        for k in strict:
            prefix = wbc.Controller(self.robot, wbc.Stack(levels[:k]), solver=self.ctrl.solver_name, dt=DT)
            sol = prefix.solve(q, v)
            for j in range(k):
                r0, r1 = sol.residuals[j], self.residuals[j]
                assert abs(r1 - r0) <= PRIORITY_TOL * max(1.0, r0), \
                    f"{self.ctrl.solver_name}: level {j} residual {r0:.6e} alone, {r1:.6e} under {len(levels) - k} more"
            COUNTS["priority_checks"] += 1


def _run(n: int, steps: int, profile: str) -> None:
    before = dict(COUNTS)
    run_state_machine_as_test(Standing, settings=settings(settings.get_profile(profile), max_examples=n,
                                                          stateful_step_count=steps))
    done = {k: COUNTS[k] - before[k] for k in COUNTS}
    print(f"\nstateful: {done}")
    assert done["sequences"] >= n and done["steps"] >= n * steps // 2


def test_random_edit_sequences_keep_priority_dynamics_and_limits():
    _run(200, 10, "wbc-default")


@pytest.mark.slow
def test_random_edit_sequences_long():
    _run(2000, 30, "wbc-slow")
