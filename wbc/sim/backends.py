"""The simulator protocol the runner drives, and the physics back-ends that implement it.

A closed-loop run (``wbc.runner.loop``) talks to its simulator only through
:class:`PhysicsSimulator`: ``measure()`` gives the sensed (q, v) in pinocchio's
coordinates, ``step(tau)`` advances one control period under the commanded torques (the
simulated driver saturates them at the robot's limits and counts ``saturated_steps``),
``push(...)`` schedules an external force, and ``t``, ``q``, ``v``, ``model``, ``data``,
``points``, ``point_forces``, ``point_positions()``, ``contact_wrench(frame)`` and ``pushes``
are read for the metrics and the viewer (``com()``, the true centre of mass, too where the object
has it; otherwise the metrics compute it with pinocchio on ``model``, ``data``). Any object with
these members plugs in the same way (a user's own, e.g. a driver for a real robot, with ``q``/``v`` its last measurement).

Back-ends (``simulator:`` in a scenario, ``wbc run --sim NAME``):

- ``pinocchio``: :class:`wbc.sim.Simulator`, ours: ABA + rigid Coulomb contacts at the
  contact points, solved by pinocchio's PGS on the Delassus matrix.
- ``mujoco``: :class:`wbc.sim.mujoco_sim.MujocoSimulator`, MuJoCo's soft contacts on
  the robot's URDF compiled by MuJoCo (needs ``pip install 'wbc[mujoco]'``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..errors import ConfigError
from .options import SimOptions

if TYPE_CHECKING:
    import pinocchio as pin

    from wbc.robot.model import RobotModel

#: simulator names a scenario or the command line may give
SIMULATORS = ("pinocchio", "mujoco")


class PhysicsSimulator(Protocol):
    """What the runner needs of a simulator (SI units; q, v in pinocchio's coordinates)."""

    model: pin.Model                               # pinocchio model of the simulated robot
    t: float                                       # simulated time, s
    q: np.ndarray                                  # (nq,) true configuration
    v: np.ndarray                                  # (nv,) true velocity
    data: pin.Data                                 # pinocchio data of ``model`` at (q, v), for the metrics
    points: list                                   # contact points: (joint id, offset in the joint frame, m)
    point_forces: np.ndarray                       # (len(points), 3) world contact force on each point, N
    pushes: list                                   # scheduled pushes (wbc.sim.Push), drawn by the viewer
    saturated_steps: int                           # control periods in which the driver clipped τ

    def measure(self) -> tuple[np.ndarray, np.ndarray]: ...
    def step(self, tau: np.ndarray) -> None: ...
    def push(self, frame: str, force, start: float, duration: float) -> None: ...
    def point_positions(self) -> np.ndarray: ...
    def contact_wrench(self, frame: str) -> np.ndarray: ...


def make_simulator(name: str, robot: RobotModel, environment: Sequence, options: SimOptions | None = None,
                   **settings) -> PhysicsSimulator:
    """The simulator ``name`` (one of :data:`SIMULATORS`) for ``robot`` in ``environment``.

    Args:
        name: the back-end, one of :data:`SIMULATORS`.
        robot: the simulated robot.
        environment: shapes of :mod:`wbc.sim.environment`.
        options: :class:`~wbc.sim.options.SimOptions` (``dt``, ``substeps``, ``tau_limits``,
            sensing, ``joint_dynamics``: the URDF's joint damping and dry friction act in the
            simulation, off by default, ...).
        **settings: its fields one by one, over ``options``.

    Raises:
        ConfigError: an unknown name or a back-end that is not installed.
    """
    o = SimOptions.of(options, settings, "make_simulator")
    if name == "pinocchio":
        from .simulator import Simulator

        return Simulator.for_robot(robot, environment, options=o)
    if name == "mujoco":
        try:
            from .mujoco_sim import MujocoSimulator
        except ImportError as exc:
            raise ConfigError(f"simulator 'mujoco' needs the mujoco package ({exc}); pip install 'wbc[mujoco]'",
                              key="simulator") from exc
        return MujocoSimulator.for_robot(robot, environment, options=o)
    raise ConfigError(f"expected one of {', '.join(SIMULATORS)}, got {name!r}", key="simulator")
