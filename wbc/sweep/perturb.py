"""Model perturbations of a sweep case: ``model.*`` key paths, which are not scenario keys.

    model.mass_scale: 1.1                  # every body's mass and rotational inertia × 1.1
    model.mass_scale.torso_2_link: 0.8     # one link (its joint's body) × 0.8, on top
    model.apply_to: simulator              # simulator (default) | controller | both

Robustness to model error means that the *simulated* robot differs from the model the
controller uses, so by default only the simulator's copy of the pinocchio model is
changed (through ``runner.run(..., model_perturbation=...)``); ``controller`` changes the
controller's model instead (the simulator keeps the nominal one), ``both`` changes both.

A scale ``s`` multiplies a body's dynamic parameters (m, m c, I): mass and rotational
inertia scale by ``s``, the centre of mass stays where it is. The pinocchio model keeps
one body per joint (links fixed to each other are merged, their frames carry no inertia
of their own), so a link name scales the whole body of the joint it hangs from (a joint
name may be given as well).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.validation.schema import number, text

from ..errors import ConfigError

APPLY_TO = ("simulator", "controller", "both")
#: scale factors allowed (unitless): a model 10× off is not a perturbation any more
SCALE_RANGE = (1e-3, 10.0)


@dataclass(frozen=True)
class Perturbation:
    """Scale factors (unitless) for the bodies of a pinocchio model."""

    mass_scale: float = 1.0
    link_scale: dict[str, float] = field(default_factory=dict)
    apply_to: str = "simulator"

    @property
    def identity(self) -> bool:
        return self.mass_scale == 1.0 and all(s == 1.0 for s in self.link_scale.values())

    def as_dict(self) -> dict:
        return {"mass_scale": self.mass_scale, "link_scale": dict(sorted(self.link_scale.items())),
                "apply_to": self.apply_to}

    def joint_scales(self, model: pin.Model) -> np.ndarray:
        """Scale per joint body (index 0, the universe, included and always 1)."""
        scales = np.full(model.njoints, self.mass_scale)
        scales[0] = 1.0
        for name, s in self.link_scale.items():
            scales[body_joint(model, name)] *= s
        return scales

    def __call__(self, model: pin.Model) -> None:
        """Scale the bodies of ``model`` in place (a copy: the runner passes the simulator's)."""
        for j, s in enumerate(self.joint_scales(model)):
            if j and s != 1.0:
                model.inertias[j] = pin.Inertia.FromDynamicParameters(s * model.inertias[j].toDynamicParameters())


def body_joint(model: pin.Model, name: str) -> int:
    """Joint index whose body holds link (body frame) or joint ``name``; ConfigError if none."""
    if model.existJointName(name):
        return int(model.getJointId(name))
    for f in model.frames:
        if f.name == name and f.type == pin.FrameType.BODY:
            return int(f.parentJoint)
    links = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
    from wbc.validation.schema import suggest

    raise ConfigError(f"no link or joint '{name}' in the robot model{suggest(name, links)}; links: "
                      f"{', '.join(links[:12])}{', ...' if len(links) > 12 else ''}")


def perturbation(values: dict[str, Any]) -> Perturbation:
    """The :class:`Perturbation` of a case's ``model.*`` values (key path -> value),
    checked (ConfigError with the key path)."""
    mass, links, apply_to = 1.0, {}, "simulator"
    for key, v in values.items():
        rest = key[len("model."):]
        if rest == "mass_scale":
            mass = number(v, key, ge=SCALE_RANGE[0], le=SCALE_RANGE[1], unit="unitless scale")
        elif rest.startswith("mass_scale."):
            links[rest[len("mass_scale."):]] = number(v, key, ge=SCALE_RANGE[0], le=SCALE_RANGE[1],
                                                      unit="unitless scale")
        elif rest == "apply_to":
            apply_to = text(v, key, choices=APPLY_TO)
        else:
            raise ConfigError("unknown model perturbation; expected model.mass_scale, model.mass_scale.<link> "
                              "or model.apply_to", key=key)
    return Perturbation(mass, links, apply_to)


def perturbed_robot(robot, pert: Perturbation):
    """A copy of the RobotModel ``robot`` whose pinocchio model is scaled by ``pert``
    (the controller's side of ``apply_to: controller|both``); ``robot`` is unchanged."""
    import dataclasses

    model = pin.Model(robot.model)
    pert(model)
    return dataclasses.replace(robot, model=model)
