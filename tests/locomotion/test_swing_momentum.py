"""The swing leg's momentum terms of the walker (:meth:`Walker.swing_momentum_terms`): the
leg's angular momentum L about the CoM and its rate L̇, checked against pinocchio's centroidal
momentum of the whole robot when only that leg moves, and its rate against a finite
difference along the motion."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.locomotion.walker import Walker
from wbc.scenario.loader import load_config


@pytest.mark.parametrize("name", ["g1_walk", "talos_walk"])
def test_swing_leg_momentum_matches_the_centroidal_momentum_when_only_that_leg_moves(name):
    sc = load_config(name)
    robot = sc.robot
    walker = Walker(sc.walk, robot, sc.stack, ctrl=None, dt=sc.dt)
    q = robot.q_default.copy()
    walker.begin(0.0, q, np.zeros(robot.nv))
    rng = np.random.default_rng(3)
    m = robot.model
    for side in ("left", "right"):
        leg = [m.idx_vs[j] for j in walker.leg_joints[side]]
        assert len(leg) >= 6                        # hip to ankle, nothing of the other leg
        other = [m.idx_vs[j] for j in walker.leg_joints["right" if side == "left" else "left"]]
        assert not set(leg) & set(other)
        v = np.zeros(robot.nv)
        a = np.zeros(robot.nv)
        v[leg] = rng.uniform(-1.0, 1.0, len(leg))
        a[leg] = rng.uniform(-5.0, 5.0, len(leg))
        robot.update(q, v)
        walker.swing_momentum_terms(q, v, a, side)
        k = robot.mass * (walker.z_com - walker.ground_z)
        d = m.createData()
        pin.computeCentroidalMomentumTimeVariation(m, d, q, v, a)
        L, Ldot = d.hg.angular, d.dhg.angular
        # only the leg moves: the robot's centroidal angular momentum is the leg's
        assert walker.ell == pytest.approx(np.array([-L[1], L[0]]) / k, rel=1e-9, abs=1e-12)
        assert walker.ell_dot == pytest.approx(np.array([-Ldot[1], Ldot[0]]) / k, rel=1e-9, abs=1e-12)
        # and the rate is the derivative of ℓ along the motion (central difference, the CoM
        # moving with the leg: the rate is about the moving CoM)
        h = 1e-6
        ells = []
        for s in (-h, h):
            qs = pin.integrate(m, q, v * s + a * s * s / 2)
            vs = v + a * s
            robot.update(qs, vs)
            walker.swing_momentum_terms(qs, vs, a, side)
            ells.append(walker.ell.copy())
        fd = (ells[1] - ells[0]) / (2 * h)
        assert walker.ell_dot is not None
        robot.update(q, v)
        walker.swing_momentum_terms(q, v, a, side)
        assert fd == pytest.approx(walker.ell_dot, rel=1e-4, abs=1e-6)
