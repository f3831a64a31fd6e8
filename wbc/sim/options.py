"""The settings of a simulator (both back-ends), in one record.

:func:`wbc.sim.backends.make_simulator`, :class:`wbc.sim.Simulator` and
:class:`wbc.sim.mujoco_sim.MujocoSimulator` take a :class:`SimOptions` (or its fields as
keywords, :class:`wbc.options.Options`); the runner builds one from its
:class:`~wbc.runner.options.RunOptions` and the scenario (``dt``, ``substeps``, ``sensing:``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..options import Options


@dataclass(frozen=True)
class SimOptions(Options):
    """How a simulator steps, senses and drives (SI units)."""

    dt: float = 1e-3
    """control period, s (one :meth:`step`)"""
    substeps: int = 1
    """physics steps per control period"""
    noise_q: float = 0.0
    """standard deviation of the measured configuration's noise, rad or m"""
    noise_v: float = 0.0
    """standard deviation of the measured velocity's noise, rad/s or m/s"""
    latency_steps: int = 0
    """control periods between a state and its measurement"""
    seed: int = 0
    """seed of the sensor noise's random draws"""
    tau_limits: np.ndarray | None = None
    """the driver's torque limits, N·m (≥ 0, inf = none), per actuated joint (na) or per dof
    (nv, unactuated entries ignored); None: no saturation (MuJoCo: the robot's ``tau_max``)"""
    joint_dynamics: bool = False
    """the URDF's joint damping and dry friction act in the simulation"""
    baumgarte: float | None = None
    """pinocchio back-end: contact position correction per step, unitless; None: 0.2 (MuJoCo: unused)"""
    margin: float | None = None
    """pinocchio back-end: contact detection margin, m; None: 2e-3 (MuJoCo: unused)"""
    contact_solver: str = "compiled"
    """pinocchio back-end: the contact PGS, :data:`wbc.sim.contact_solver.SOLVERS`"""
    actuated: np.ndarray | None = None
    """pinocchio back-end: (nv,) bool mask of the driven dofs; None: all (``for_robot``: the robot's)"""
    differential_drive: bool = False
    """pinocchio back-end: the planar base is driven by two wheels (``for_robot``: the robot's)"""
    joint_limits: bool = True
    """MuJoCo back-end: the URDF's joint position limits act"""
    inertias: str = "model"
    """MuJoCo back-end: the bodies' inertias, the pinocchio ``"model"``'s or the ``"urdf"``'s inertials"""
    link_geoms: Sequence[Any] = ()
    """MuJoCo back-end: the robot's collision geometries added as MuJoCo geoms
    (:meth:`wbc.collision.model.CollisionModel.link_geometries`)"""
