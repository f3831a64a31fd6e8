"""The ``walk:`` section of a scenario: a walk the run's walker
(:mod:`wbc.locomotion.walker`) makes, checked here against the robot and the stack.

    walk:
      command: {v_x: 0.25, v_y: 0.0, omega: 0.0, steps: 10}   # m/s, m/s, rad/s; then a stop step
      # or footsteps: [{side: right, x: 0.2, y: -0.085, yaw: 0.0}, ...]   (the start's walking
      #   frame: the feet's mid-point, x forward; m, rad)
      timing: {single: 0.6, double: 0.2, first: 0.6, last: 0.8, ramp: 0.1}   # s
      step_height: 0.05                     # m, the swing apex above the ground
      limits: {max_length: 0.25, min_width: 0.12, max_width: 0.35, max_turn: 0.35}   # m, rad
      start: 0.0                            # s, the first double support begins
      contacts: {left: left_foot, right: right_foot}   # the robot's sole contacts
      swing_kp: 400.0                       # 1/s², the swing-foot task's gain
      events:                               # run-time changes (s): a new command, a stop
        - {time: 3.0, command: {v_x: 0.1, v_y: 0.0, omega: 0.0, steps: 4}}
        - {time: 5.0, stop: true}

Defaults from the robot (the start posture's CoM height z_c above the soles, the soles'
half sizes): ``step_height`` 0.06 z_c; ``limits.max_length`` 0.3 z_c, ``min_width`` the
soles' width plus 2 cm, ``max_width`` 0.4 z_c, ``max_turn`` 0.35 rad. A command whose step
breaks the limits, footsteps that overlap or break them, a double support shorter than its
two force ramps, a walk longer than the run: a ConfigError naming the key. A run-time
command beyond the limits is clipped, with a warning (:meth:`Walker.command`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from wbc.errors import ConfigError
from wbc.locomotion.footsteps import Footstep, StepLimits, check_plan, from_command
from wbc.locomotion.plan import Command
from wbc.locomotion.timing import Timing, schedule
from wbc.locomotion.walker import SIDES, WalkSpec, _from_frame, pose2d
from wbc.tasks.com import CoM
from wbc.validation.schema import boolean, integer, mapping, number, sequence, text

_KEYS = {"command", "footsteps", "timing", "step_height", "limits", "start", "contacts", "swing_kp", "events"}
MAX_STEPS = 1000


def start_feet(robot, contacts: dict[str, str]) -> tuple[dict[str, Footstep], float, float]:
    """The feet's poses at the robot's start posture, the CoM height above them (m) and the
    soles' smallest half width (m)."""
    m = robot.model
    d = m.createData()
    q = robot.q_default
    c = pin.centerOfMass(m, d, q)
    pin.updateFramePlacements(m, d)
    feet, zs, half = {}, [], np.inf
    for side in SIDES:
        surf = robot.contact(contacts[side])
        M = d.oMf[robot.frame_id(surf.frame)]
        x, y, yaw = pose2d(M)
        feet[side] = Footstep(side, x, y, yaw)
        zs.append(M.translation[2])
        half = min(half, getattr(surf, "half_width", 0.0) or 0.0)
    return feet, float(c[2] - np.mean(zs)), float(half if np.isfinite(half) else 0.0)


def _command(spec: Any, key: str, steps_default: int | None = None) -> tuple[float, float, float, int]:
    spec = mapping(spec, key, allowed={"v_x", "v_y", "omega", "steps"},
                   what="a walking command {v_x, v_y (m/s), omega (rad/s), steps}")
    vx = number(spec.get("v_x", 0.0), f"{key}.v_x", ge=-10, le=10, unit="m/s")
    vy = number(spec.get("v_y", 0.0), f"{key}.v_y", ge=-10, le=10, unit="m/s")
    om = number(spec.get("omega", 0.0), f"{key}.omega", ge=-10, le=10, unit="rad/s")
    if "steps" not in spec and steps_default is None:
        raise ConfigError("missing (the number of steps to walk, then one that brings the feet side by side)",
                          key=f"{key}.steps")
    steps = integer(spec.get("steps", steps_default), f"{key}.steps", ge=0, le=MAX_STEPS)
    return vx, vy, om, steps


def walk_section(spec: Any, robot, stack, duration: float) -> WalkSpec | None:
    """``walk:`` -> a :class:`WalkSpec` (module docstring); None without the section."""
    if spec is None:
        return None
    spec = mapping(spec, "walk", allowed=_KEYS, what="a walk mapping (command or footsteps, timing, ...)")
    if ("command" in spec) == ("footsteps" in spec):
        raise ConfigError("needs exactly one of command (v_x, v_y, omega, steps) or footsteps (a list of poses)",
                          key="walk")
    c = mapping(spec.get("contacts", {}), "walk.contacts", allowed=set(SIDES))
    contacts = {side: text(c.get(side, f"{side}_foot"), f"walk.contacts.{side}", what="a contact of the robot")
                for side in SIDES}
    for side in SIDES:
        if contacts[side] not in robot.contacts:
            raise ConfigError(f"'{contacts[side]}' is not a contact of robot '{robot.name}' (its contacts: "
                              f"{sorted(robot.contacts)})", key=f"walk.contacts.{side}")
    _check_stack(stack, contacts)
    feet, z_c, half = start_feet(robot, contacts)
    t = mapping(spec.get("timing", {}), "walk.timing", allowed={"single", "double", "first", "last", "ramp"})
    d = Timing()
    timing = Timing(**{k: number(t.get(k, getattr(d, k)), f"walk.timing.{k}", gt=0, le=10, unit="s")
                       for k in ("single", "double", "first", "last", "ramp")})
    timing.check("walk.timing")
    lim = mapping(spec.get("limits", {}), "walk.limits", allowed={"max_length", "min_width", "max_width", "max_turn"})
    auto = {"max_length": 0.3 * z_c, "min_width": 2 * half + 0.02, "max_width": 0.4 * z_c, "max_turn": 0.35}
    limits = StepLimits(**{k: number(lim.get(k, auto[k]), f"walk.limits.{k}", gt=0, le=5,
                                     unit="rad" if k == "max_turn" else "m") for k in auto})
    if limits.min_width > limits.max_width:
        raise ConfigError(f"min_width {limits.min_width:g} m is over max_width {limits.max_width:g} m",
                          key="walk.limits.min_width")
    out = WalkSpec(timing=timing, limits=limits, contacts=contacts,
                   step_height=number(spec.get("step_height", 0.06 * z_c), "walk.step_height", gt=0, le=0.5, unit="m"),
                   start=number(spec.get("start", 0.0), "walk.start", ge=0, lt=duration, unit="s"),
                   swing_kp=number(spec.get("swing_kp", 400.0), "walk.swing_kp", gt=0, le=1e5, unit="1/s²"))
    period = timing.single + timing.double
    if "command" in spec:
        vx, vy, om, n = _command(spec["command"], "walk.command")
        out.command = Command(vx, vy, om, n)
        steps = from_command(feet, (vx, vy, om), period, n, limits)
        check_plan(feet, steps, limits, "walk.command")        # the start's width against the limits too
    else:
        out.footsteps = []
        for i, s in enumerate(sequence(spec["footsteps"], "walk.footsteps", min_len=1, max_len=MAX_STEPS,
                                       what="a list of footsteps {side, x, y, yaw}")):
            k = f"walk.footsteps[{i}]"
            s = mapping(s, k, allowed={"side", "x", "y", "yaw"}, required=("side", "x", "y"))
            out.footsteps.append(Footstep(text(s["side"], f"{k}.side", choices=SIDES),
                                          number(s["x"], f"{k}.x", ge=-100, le=100, unit="m"),
                                          number(s["y"], f"{k}.y", ge=-100, le=100, unit="m"),
                                          number(s.get("yaw", 0.0), f"{k}.yaw", ge=-7, le=7, unit="rad")))
        steps = [_from_frame(s, feet) for s in out.footsteps]
        check_plan(feet, steps, limits, "walk.footsteps")
    end = schedule(feet, steps, timing, out.start)[-1].t1
    for i, ev in enumerate(sequence(spec.get("events", []), "walk.events", what="a list of walk events")):
        k = f"walk.events[{i}]"
        ev = mapping(ev, k, allowed={"time", "command", "stop"}, required=("time",))
        when = number(ev["time"], f"{k}.time", ge=0, lt=duration, unit="s; inside the run")
        if ("command" in ev) == ("stop" in ev):
            raise ConfigError("needs exactly one of command or stop", key=k)
        if "stop" in ev:
            if not boolean(ev["stop"], f"{k}.stop"):
                raise ConfigError("must be true (a stop event)", key=f"{k}.stop")
            out.changes.append((when, None))
        else:
            vx, vy, om, n = _command(ev["command"], f"{k}.command")
            try:                # beyond the limits: refused here (at run time it would be clipped)
                from_command(feet, (vx, vy, om), period, n, limits)
            except ConfigError as exc:
                raise ConfigError(exc.message, key=(exc.key or "").replace("walk.command", f"{k}.command")) from None
            out.changes.append((when, Command(vx, vy, om, n)))
            end = max(end, when + timing.first + (n + 1) * period + timing.last)
    out.changes.sort(key=lambda e: e[0])
    if not out.changes and end > duration + 1e-9:
        raise ConfigError(f"the walk ends at t = {end:.3f} s, after the run's end ({duration:g} s): lengthen "
                          "duration or shorten the walk", key="walk")
    return out


def _check_stack(stack, contacts: dict[str, str]) -> None:
    coms = [t for t in stack if isinstance(t, CoM)]
    if len(coms) != 1:
        raise ConfigError(f"a walk needs exactly one com task in the stack, found {len(coms)}", key="walk")
    for side in SIDES:
        held = [t for t in stack.contacts() if t.contact == contacts[side]]
        if not held:
            raise ConfigError(f"a walk needs a contact task on '{contacts[side]}' in the stack (both feet down at "
                              "the start)", key=f"walk.contacts.{side}")
