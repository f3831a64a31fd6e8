"""Where the own simulator's step goes inside the talos_balance closed loop (hqp, pinocchio):
its pieces timed in place, one ``perf_counter_ns`` between each, medians (µs) over the run (#26).
The step is run as :meth:`Simulator._substep` runs it on this scenario (no joint dynamics, no
push, no differential drive, the compiled contact step), with a clock read between the pieces;
the figures include the clock's own cost (~0.05 µs a read).

    PYTHONPATH=. python benchmarks/sim_substep_split.py [SECONDS]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import pinocchio as pin

from wbc.runner import loop
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config
from wbc.sim import simulator as simmod
from wbc.sim.simulator import Simulator

TIMES: dict[str, list[int]] = {}
ORIGINAL = Simulator._substep


def _note(key: str, t0: int) -> int:
    t1 = time.perf_counter_ns()
    TIMES.setdefault(key, []).append(t1 - t0)
    return t1


def _timed_kinematics(self):
    """Both paths' start, timed: the joint Jacobians (without forward kinematics when the data is
    at q already) and the frames' placements; (the start's clock, the last lap's)."""
    t_start = t = time.perf_counter_ns()
    m, d, q = self.model, self.data, self.q
    if self._kin_q is not None and self._kin_q == q.tobytes():
        t = _note("(kin key)", t)
        pin.computeJointJacobians(m, d)
        t = _note("computeJointJacobians", t)
    else:
        t = _note("(kin key)", t)
        pin.computeJointJacobians(m, d, q)
        t = _note("computeJointJacobians(q)", t)
    pin.updateFramePlacements(m, d)
    return t_start, _note("updateFramePlacements", t)


def timed_substep(self, tau):
    """The default path of :meth:`Simulator._substep`, piece by piece (its other paths: the original)."""
    if self.joint_dynamics is not None or self.differential_drive or not self._fused or self.pushes:
        return ORIGINAL(self, tau)
    if hasattr(self, "_contact_motion"):
        return _timed_one_call(self, tau)
    t_start, t = _timed_kinematics(self)
    m, d, h = self.model, self.data, self.h
    q, v = self.q, self.v
    self._external_forces()
    t = _note("_external_forces", t)
    J, frames, depths, mus, ids = self._contact_rows()
    t = _note("_contact_rows", t)
    dm, dd = self._dyn_model, self._dyn_data
    Minv = pin.computeMinverse(dm, dd, q)
    t = _note("computeMinverse", t)
    nle = pin.nonLinearEffects(m, d, q, v)
    t = _note("nonLinearEffects", t)
    v_free, u, w = simmod.cr.free_motion(Minv, tau, nle, v, h, self._free_flyer)
    t = _note("free_motion", t)
    if self._free_flyer:
        v_free[:3] = pin.exp3(w) @ u
    t = _note("exp3 @ u", t)
    settings = (self.baumgarte, h, self.over_relax, simmod.PGS_MAX_ITERATIONS, simmod.PGS_ABSOLUTE_PRECISION,
                simmod.PGS_RELATIVE_PRECISION)
    t = _note("(settings tuple)", t)
    v, self.pgs_sweeps, _, finite = simmod.cr.contact_step((J, depths, mus, frames, ids), Minv, v_free, settings,
                                                           self._pgs_state)
    t = _note("contact_step", t)
    if not finite:
        self.solver_failures += 1
    self.v = v
    self.q = pin.integrate(m, q, v * h)
    t = _note("integrate", t)
    self.t += h
    _note("(substep total)", t_start)


def _timed_one_call(self, tau):
    """The same, for a tree whose step has one compiled call after the contact search (#26,
    branch sim3: ``Simulator._contact_motion``)."""
    t_start, t = _timed_kinematics(self)
    m, d, h = self.model, self.data, self.h
    q, v = self.q, self.v
    k = simmod.cr.find_contacts_and_spin(self._point_args, self._shape_args, self.margin, self._Jw,
                                         self._contact_out, (v, h, self._free_flyer, self._w))
    t = _note("find_contacts_and_spin", t)
    if not k:
        return ORIGINAL(self, tau)
    Minv = pin.computeMinverse(self._dyn_model, self._dyn_data, q)
    t = _note("computeMinverse", t)
    nle = pin.nonLinearEffects(m, d, q, v)
    t = _note("nonLinearEffects", t)
    R = pin.exp3(self._w) if self._free_flyer else self._no_rotation
    t = _note("exp3", t)
    settings = (self.baumgarte, h, self.over_relax, simmod.PGS_MAX_ITERATIONS, simmod.PGS_ABSOLUTE_PRECISION,
                simmod.PGS_RELATIVE_PRECISION, self._free_flyer)
    t = _note("(settings tuple)", t)
    v, dq, self.pgs_sweeps, finite = simmod.cr.contact_motion(k, self._motion_args, (Minv, tau, nle, v, R),
                                                              settings, self._pgs_state)
    t = _note("contact_motion", t)
    if not finite:
        self.solver_failures += 1
    self.v = v
    self.q = pin.integrate(m, q, dq)
    t = _note("integrate", t)
    self.t += h
    _note("(substep total)", t_start)


def main(seconds: float = 2.0) -> None:
    warnings.simplefilter("ignore")
    Simulator._substep = timed_substep
    f = Simulator.step

    def step(self, tau):
        t0 = time.perf_counter_ns()
        f(self, tau)
        _note("sim.step", t0)

    Simulator.step = step
    loop.run(load_config(SCENARIOS_DIR / "talos_balance.yaml"), solver="hqp", duration=seconds)
    print(f"pinocchio {pin.__version__}, talos_balance {seconds} s, medians after the first 50 steps, µs")
    for k, x in TIMES.items():
        print(f"{k:28s} {np.median(x[50:]) / 1e3:7.2f}  (p90 {np.percentile(x[50:], 90) / 1e3:7.2f}, n {len(x)})")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 2.0)
