"""Interaction runs (5.3.5): what the controller is told of the external forces, and the
glass-of-water figures; :func:`wbc.runner.loop.run` drives it through one :class:`ExternalForceRun`.

A scenario's section::

    interaction:
      glass: hand                  # the frame task holding the glass (required)
      elbow: arm_4_link            # the frame whose displacement is reported (default: the first push's)
      base: base                   # the frame that displacement is measured in (default: base, else the root)
      external_force: simulator    # none | simulator | observer (default none)
      observer_gain: 50.0          # K_O of the momentum observer, 1/s (default 50)

``external_force`` is the τ̂_e the controller puts in its dynamics (``Controller.solve(...,
external_torque=τ̂_e)``, so every level sees M q̈ + h − τ̂_e = Sᵀτ + J_fᵀf and the
null-space impedance yields to it, :mod:`wbc.tasks.null_space_impedance`):

- ``none``: nothing, the chapter's 5.42-5.46 as written (the higher tasks take the push's
  part outside their null space, J_k M_c⁻¹ τ_e);
- ``simulator``: the scenario's true pushes, τ̂_e = Σ J_p(q)ᵀ f over the pushes acting at t
  (J_p the world-aligned Jacobian of the pushed frame's origin), a perfect sensor at the
  pushed point;
- ``observer``: the generalised-momentum observer's r (:mod:`wbc.interaction.momentum_observer`)
  from the measured q, v and the torques sent, no sensor at the push: the 6-axis wrench of
  each contact task's frame (``contact_wrench``, a foot's force/torque sensor) is given to
  it as a known force, J_sole(q)ᵀ w in the sole's LOCAL axes, so that r estimates the rest.

On a differential drive the lateral velocity coordinate (planar v_y) of τ̂_e is set to 0:
along it the wheels' constraint force answers whatever τ does, and fed back through an
estimate it would integrate without bound. The observer runs in every interaction run; its
wrench at the pushed frame (``MomentumObserver.wrench``) is reported against the true push
as ``push_estimate``: the mean of the estimated force over the push's second half (from
5/K_O s after its start if that is later; none if the push is shorter), its relative error,
and the observer's time constant.
Metrics: those of :class:`~wbc.interaction.glass_metrics.GlassMetrics`, and ``external_force`` (the source).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.errors import ConfigError, WbcError, placed
from wbc.interaction.glass_metrics import GlassMetrics
from wbc.interaction.momentum_observer import MomentumObserver
from wbc.tasks.frame import Frame
from wbc.validation.schema import mapping, number, text

SOURCES = ("none", "simulator", "observer")
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_KEYS = {"glass", "elbow", "base", "external_force", "observer_gain"}


@dataclass(frozen=True)
class InteractionSpec:
    """A validated ``interaction:`` section (frames as URDF names)."""

    glass: str            # the glass's frame task (its name in the stack)
    glass_frame: str
    elbow: str
    base: str
    external_force: str = "none"
    observer_gain: float = 50.0


def interaction_section(spec: Any, robot, stack, pushes: list[dict]) -> InteractionSpec | None:
    """``interaction:`` -> :class:`InteractionSpec` (None when absent); ConfigError with the key path."""
    if spec is None:
        return None
    spec = mapping(spec, "interaction", allowed=_KEYS, required=("glass",))
    glass = text(spec["glass"], "interaction.glass", what="the name of a frame task of the stack")
    tasks = {t.name: t for t in stack if isinstance(t, Frame)}
    if glass not in tasks:
        raise ConfigError(f"must name a frame task of the stack, got {glass!r}; frame tasks: {sorted(tasks)}",
                          key="interaction.glass")

    def frame(key: str, default: str | None) -> str:
        name = text(spec.get(key, default), f"interaction.{key}", what="a frame name or alias")
        try:
            return robot.model.frames[robot.frame_id(name)].name
        except WbcError as exc:
            raise placed(exc, f"interaction.{key}", cls=ConfigError) from exc

    if "elbow" not in spec and not pushes:
        raise ConfigError("missing: give the frame whose displacement to report (no push names one)",
                          key="interaction.elbow")
    root = robot.model.frames[1].name if len(robot.model.frames) > 1 else "universe"
    base_default = "base" if "base" in robot.frames else root
    source = text(spec.get("external_force", "none"), "interaction.external_force", choices=SOURCES)
    gain = number(spec.get("observer_gain", 50.0), "interaction.observer_gain", gt=0, le=1e4, unit="1/s")
    return InteractionSpec(glass=glass, glass_frame=robot.model.frames[robot.frame_id(tasks[glass].frame)].name,
                           elbow=frame("elbow", pushes[0]["frame"] if pushes else None),
                           base=frame("base", base_default), external_force=source, observer_gain=gain)


class ExternalForceRun:
    """One run's external-force source and glass metrics (module docstring). Per cycle the
    runner calls :meth:`before_solve` (returns τ̂_e for ``Controller.solve``) and, after the
    simulator's step, :meth:`after_step`; :meth:`summary` gives the metrics."""

    def __init__(self, spec: InteractionSpec, robot, sim, stack, pushes: list[dict]) -> None:
        self.spec, self.robot, self.stack = spec, robot, stack
        self.pushes = pushes
        self.data = robot.model.createData()
        first = min(pushes, key=lambda p: p["start"]) if pushes else None
        window = None if first is None else (first["start"], first["start"] + first["duration"])
        self.first = first
        self.metrics = GlassMetrics(sim.model, spec.glass_frame, spec.elbow, spec.base, window)
        self.observer = MomentumObserver(robot, spec.observer_gain)
        self.sensors = [robot.frame_id(robot.contact(c.contact).frame) for c in stack.contacts()]
        self.lateral = robot.differential_drive
        self._tau: np.ndarray | None = None          # the torque sent over the last interval
        self._known: np.ndarray | None = None        # the contact sensors' generalised force over it
        self._q: np.ndarray | None = None
        self._est: list[np.ndarray] = []

    def _jacobians(self, q: np.ndarray) -> None:
        pin.computeJointJacobians(self.robot.model, self.data, q)
        pin.updateFramePlacements(self.robot.model, self.data)

    def true_push(self, t: float, q: np.ndarray) -> np.ndarray:
        """Σ J_p(q)ᵀ f over the pushes acting at t (nv)."""
        tau = np.zeros(self.robot.nv)
        self._jacobians(q)
        for p in self.pushes:
            if p["start"] <= t < p["start"] + p["duration"]:
                fid = self.robot.model.getFrameId(p["frame"])
                tau += pin.getFrameJacobian(self.robot.model, self.data, fid, LWA)[:3].T @ p["force"]
        return tau

    def before_solve(self, t: float, q: np.ndarray, v: np.ndarray, sim) -> np.ndarray | None:
        """Record the glass figures on the simulator's state at t, advance the observer with the
        measured (q, v), and return the τ̂_e the controller is to use (None for ``none``)."""
        task = self.stack[self.spec.glass] if self.spec.glass in self.stack else None
        self.metrics.record(t, sim.q, task.target if task is not None else None)
        if self._tau is None:
            self.observer.reset(q, v, t)
        else:
            self.observer.update(q, v, self._tau, t, tau_known=self._known)
            self._record_estimate(t, q)
        self._q = q
        src = self.spec.external_force
        if src == "none":
            return None
        tau_e = self.true_push(t, q) if src == "simulator" else self.observer.r.copy()
        if self.lateral:
            tau_e[1] = 0.0
        return tau_e

    def after_step(self, sim, sol) -> None:
        """Keep the torque just sent and what the contact sensors read over that step."""
        self._tau = sol.tau_full.copy()
        if self.sensors:
            assert self._q is not None, "before_step has run this cycle"
            self._jacobians(self._q)
            known = np.zeros(self.robot.nv)
            for fid in self.sensors:
                J = pin.getFrameJacobian(self.robot.model, self.data, fid, pin.ReferenceFrame.LOCAL)
                known += J.T @ sim.contact_wrench(self.robot.model.frames[fid].name)
            self._known = known

    def _record_estimate(self, t: float, q: np.ndarray) -> None:
        p = self.first
        if p is None:
            return
        if p["start"] + max(0.5 * p["duration"], 5.0 / self.spec.observer_gain) <= t < p["start"] + p["duration"]:
            self._est.append(self.push_wrench(p["frame"], q)[:3])

    def push_wrench(self, frame: str, q: np.ndarray, damping: float = 1e-6) -> np.ndarray:
        """The observer's wrench at ``frame`` (6, N and N·m, world axes, about its origin):
        h = (J Jᵀ + λ²I)⁻¹ J r over the coordinates of r an external force may load, J the
        frame's world-aligned Jacobian (on a differential drive the lateral coordinate, which
        carries the wheels' constraint force, is left out)."""
        J = self.observer.frame_jacobian(q, self.robot.model.getFrameId(frame))
        r = self.observer.r
        if self.lateral:
            J, r = np.delete(J, 1, axis=1), np.delete(r, 1)
        return np.linalg.solve(J @ J.T + damping ** 2 * np.eye(6), J @ r)

    def summary(self) -> dict:
        out = {**self.metrics.summary(), "external_force": self.spec.external_force}
        if self._est and self.first is not None:
            f = np.asarray(self.first["force"], float)
            est = np.mean(self._est, axis=0)
            out["push_estimate"] = {"frame": self.first["frame"], "force": f.tolist(), "estimated": est.tolist(),
                                    "error_rel": float(np.linalg.norm(est - f) / max(np.linalg.norm(f), 1e-12)),
                                    "time_constant": 1.0 / self.spec.observer_gain}
        return out
