"""Hybrid force/motion selection as a stack construct (5.29-5.33, 5.3.3).

A contact with an environment that constrains m directions splits the contact frame's twist
and wrench spaces into reciprocal subspaces (5.31-5.33):

    h_e = S_f λ,   v_e = S_v ν,   S_fᵀ S_v = 0,

S_f (6 × m) the directions the environment can push along (λ the force there) and S_v
(6 × (6 − m)) the directions the end effector can move along (ν its velocity there). For a
hand on a table (a point contact, normal n): m = 1, S_f = (n, 0), S_v the two tangents and the
three rotations. The hybrid scheme controls λ along S_f and ν along S_v, independently.

In the stack this is three tasks on one contact frame:

- the contact, ``sliding`` (:class:`~wbc.tasks.Contact`): its rows hold the constrained
  directions only, J_φ q̈ + J̇_φ q̇ = 0 (5.30 differentiated): the natural constraint;
- a :class:`~wbc.tasks.Force` task whose ``directions`` are S_f (its rows on the contact's
  force variables: λ = f_λ with measured-force PI feedback);
- a motion task (a :class:`~wbc.tasks.Frame` on the contact's frame) whose axes are S_v
  (its rows on q̈: ν̇ = α_ν).

The force task names its motion partner (``motion:``); :func:`check_hybrid` checks the
pair: both tasks exist, the motion task is a frame task on the contact's frame, and
max |S_fᵀ S_v| ≤ 1e-9 with both sets of directions in world-aligned axes at the robot's
state (a point contact's force is world-aligned already; a surface's LOCAL wrench is turned
by its frame's rotation). Why that suffices for decoupling: S_v's rows act on q̈ along
directions in which the contact's rows do not, and S_f's rows act on f alone, so no
motion target changes the force rows' solution and no force target changes the motion rows'
(tests/tasks/test_force_task.py checks it on random states, both solvers).

:func:`hybrid_force_motion` builds the force and motion tasks from one selection, so that
S_v is the complement of S_f by construction. The frame task takes world-axis masks: S_v must
then be made of world axes (the force directions world axes, as on a horizontal table).
"""

from __future__ import annotations

import numpy as np

from wbc.errors import ConfigError, HybridError, StackError
from wbc.tasks.contact import Contact
from wbc.tasks.force import Force, selection_basis
from wbc.tasks.frame import Frame


def wrench_directions(force: Force, contact: Contact, robot) -> np.ndarray:
    """S_f in world-aligned wrench coordinates (f, τ), 6 × m, at ``robot``'s current state
    (``robot.update`` done, or the default posture's placements)."""
    surface = contact.surface(robot)
    S, _ = force.selection(surface.force_dim)
    if surface.kind == "point":
        return np.vstack([S, np.zeros_like(S)])
    R = robot.frame_placement(robot.frame_id(surface.frame)).rotation
    return np.vstack([R @ S[:3], R @ S[3:]])


def motion_directions(motion: Frame) -> np.ndarray:
    """S_v of a frame task: the unit vectors of its controlled axes, world-aligned, 6 × k."""
    return np.eye(6)[:, motion.axes]


def reciprocity(force: Force, contact: Contact, motion: Frame, robot) -> float:
    """max |S_fᵀ S_v| (0 for reciprocal subspaces, 5.33)."""
    return float(np.abs(wrench_directions(force, contact, robot).T @ motion_directions(motion)).max())


def check_pair(force: Force, stack, robot, tol: float = 1e-9) -> tuple[Contact, Frame]:
    """(the contact task, the motion task) of the hybrid pair ``force`` makes in ``stack``,
    checked (module docstring) at ``robot``'s state; raises :class:`HybridError`."""
    contact = next((t for t in stack if isinstance(t, Contact) and t.name == force.contact), None)
    if contact is None:
        raise HybridError(f"task '{force.name}': the stack has no contact task '{force.contact}'")
    motion = next((t for t in stack if t.name == force.motion), None)
    if not isinstance(motion, Frame):
        what = "no task" if motion is None else f"a {motion.kind} task"
        raise HybridError(f"task '{force.name}': motion must name a frame task of the stack, '{force.motion}' "
                          f"is {what}")
    frame = contact.surface(robot).frame
    if robot.frame_id(motion.frame) != robot.frame_id(frame):
        raise HybridError(f"task '{force.name}': its motion task '{motion.name}' drives frame '{motion.frame}', "
                          f"not the contact's frame '{frame}'")
    r = reciprocity(force, contact, motion, robot)
    if r > tol:
        raise HybridError(f"task '{force.name}': the force directions S_f and the axes S_v of motion task "
                          f"'{motion.name}' are not reciprocal (max |S_fᵀ S_v| = {r:.3g}, 5.33); leave the "
                          "force directions out of its mask")
    return contact, motion


def check_hybrid(stack, robot, tol: float = 1e-9) -> list[tuple[Force, Contact, Frame]]:
    """Every hybrid pair of the stack (force tasks with a ``motion`` partner), checked by
    :func:`check_pair`."""
    return [(f, *check_pair(f, stack, robot, tol)) for f in stack if isinstance(f, Force) and f.motion is not None]


def motion_mask(Sf_world: np.ndarray) -> list[bool]:
    """The frame-task mask spanning the complement S_v of ``Sf_world`` (6 × m), world axes;
    HybridError when that complement is not made of world axes."""
    _, Sv = selection_basis(Sf_world, owner="hybrid force/motion")
    flags = np.abs(Sv).sum(axis=1) > 1e-9
    if int(flags.sum()) != Sv.shape[1] or np.abs(np.abs(Sv).sum(axis=0) - 1.0).max() > 1e-9:
        raise HybridError("hybrid force/motion: the force directions must be world axes here (the frame task's mask "
                          f"selects world axes); S_v = {np.round(Sv, 3).tolist()}")
    return [bool(f) for f in flags]


def hybrid_force_motion(robot, contact: Contact, target=10.0, directions=None, motion_name: str | None = None,
                        force: dict | None = None, motion: dict | None = None) -> tuple[Force, Frame]:
    """The force task (directions S_f, ``target`` λ_D) and the motion task (a frame task on the
    contact's frame whose mask is S_v, the complement of S_f) of a hybrid pair on ``contact``
    (bound to ``robot``); ``force`` and ``motion`` are the two tasks' other keyword arguments."""
    surface = contact.surface(robot)
    f = Force(contact.name, target=target, directions=directions, motion=motion_name or f"{contact.contact}_motion",
              **(force or {}))
    Sf = wrench_directions(f, contact, robot)
    m = Frame(surface.frame, name=f.motion, mask=motion_mask(Sf), **(motion or {}))
    return f, m


def check_force_tasks(stack, contacts: dict[str, Contact], where_of: dict[str, str], robot) -> None:
    """A scenario's force tasks against its stack (``contacts``: contact tasks by name;
    ``where_of``: each task's key path): each names a contact task, its directions have that
    contact's force size, and a ``motion`` partner makes a reciprocal pair (:func:`check_pair`).
    Raises :class:`ConfigError` at the force task's key."""
    for t in stack:
        if not isinstance(t, Force):
            continue
        where = where_of[t.name]
        c = contacts.get(t.contact)
        if c is None:
            raise ConfigError(f"must name a contact task of the stack, got '{t.contact}'; contact tasks: "
                              f"{sorted(contacts)}", key=f"{where}.contact")
        try:
            t.selection(c.force_dim)
        except StackError as exc:
            raise ConfigError(exc.message, key=f"{where}.directions") from exc
        if t.motion is not None:
            try:
                check_pair(t, stack, robot)
            except HybridError as exc:
                raise ConfigError(exc.message, key=f"{where}.motion") from exc
