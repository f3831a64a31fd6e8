"""Pinocchio's arrays as views held once: what a compiled task row reads without crossing the
bindings (each crossing ~1 µs, about twice that in a control cycle).

Pinocchio refreshes ``data.J``, ``data.oMf``, ``data.oMi``, ``data.v``, ``data.a``, the CoM's
arrays, ``data.M`` and ``data.nle`` in place at every ``RobotModel.update`` (checked on pinocchio 4.1 and 3.8), so a view
taken once follows every later state of the same ``data`` object; :class:`HeldViews` holds them
for one ``data`` (``RobotModel`` takes them again when its ``data`` is another, and drops them
when pickled or copied: a copied view would no longer follow).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

__all__ = ["FrameArrays", "HeldViews", "frame_support", "joint_rotations"]


def frame_support(model: pin.Model, frame_id: int) -> np.ndarray:
    """Whether each velocity coordinate moves the frame (nv bools): the coordinates of the
    joints from the root to the frame's parent joint (``model.supports``).

    Args:
        model: the pinocchio model.
        frame_id: pinocchio frame index.
    """
    out = np.zeros(model.nv, dtype=np.bool_)
    for j in model.supports[model.frames[frame_id].parentJoint]:
        if j:
            jm = model.joints[j]
            out[jm.idx_v:jm.idx_v + jm.nv] = True
    return out


def joint_rotations(data: pin.Data) -> np.ndarray | None:
    """Every joint's world rotation ``data.oMi[j].rotation`` as one (njoints × 3 × 3) view that
    pinocchio refreshes in place, or None where its storage is not laid out as one.

    Each ``oMi[j].rotation`` is already a view on the data's own storage (an aligned vector of
    SE3, one placement after the other); the array spans them with the vector's stride, and is
    returned only if every joint's own view has exactly that address and strides (checked here,
    joint by joint), so reading it is reading the bindings' views, without one crossing a joint
    (~1-3 µs each). ``R[j] @ x`` rotates a vector of joint j's frame into the world.

    Args:
        data: the pinocchio data (its ``oMi``).
    """
    views = [data.oMi[j].rotation for j in range(len(data.oMi))]
    first = views[0]
    if first.flags.owndata or first.strides != (8, 24) or first.dtype != np.float64:
        return None
    base = first.__array_interface__["data"][0]
    stride = views[1].__array_interface__["data"][0] - base if len(views) > 1 else 96
    out = np.lib.stride_tricks.as_strided(first, shape=(len(views), 3, 3), strides=(stride, 8, 24), writeable=False)
    for j, v in enumerate(views):
        if v.__array_interface__["data"][0] != base + j * stride or v.strides != (8, 24) or v.flags.owndata:
            return None
    return out


class FrameArrays(NamedTuple):
    """One frame's pinocchio arrays, as views pinocchio refreshes in place (each read through
    the bindings costs ~1 µs; :meth:`RobotModel.frame_arrays` holds them): ``views`` = (the
    velocity coordinates that move the frame (nv bools), its placement's R (3 × 3) and p (3,
    m), its parent joint's rotation Rᵢ, the joint-to-frame placement's jRf and jpf (constant
    copies), the joint's spatial velocity v and acceleration a of the a = 0 forward pass (6,
    its own frame, linear first), a scratch 12-vector (the frame's velocity and drift)), what
    :func:`wbc.tasks.velocity_frames.frame_motion_rows` reads."""

    views: tuple
    #: the frame's placement (pinocchio's ``data.oMf[fid]``, refreshed in place)
    placement: pin.SE3

    @staticmethod
    def of(model: pin.Model, data: pin.Data, fid: int) -> FrameArrays:
        """The arrays of frame ``fid`` (model and data of one robot)."""
        frame = model.frames[fid]
        j = frame.parentJoint
        support = frame_support(model, fid)
        oMf = data.oMf[fid]
        jMf = frame.placement
        return FrameArrays((support, oMf.rotation, oMf.translation, data.oMi[j].rotation,
                            np.asfortranarray(jMf.rotation.copy()), jMf.translation.copy(), data.v[j].vector,
                            data.a[j].vector, np.zeros(12)), oMf)


class HeldViews:
    """One ``data`` object's held views: ``J`` (``data.J``, 6 × nv), the CoM's ``com``,
    ``vcom``, ``acom`` (3 each) and ``Jcom`` (3 × nv), ``M`` (``data.M``, nv × nv) and ``nle``
    (``data.nle``, nv), and each frame's :class:`FrameArrays` (:meth:`frame`, taken at its first
    use).

    Args:
        data: the pinocchio data; None: nothing held yet.
    """

    __slots__ = ("data", "J", "com", "vcom", "acom", "Jcom", "M", "nle", "frames")

    def __init__(self, data: pin.Data | None) -> None:
        self.data: pin.Data | None = data
        self.frames: dict[int, FrameArrays] = {}
        if data is not None:
            self.J, self.Jcom = data.J, data.Jcom
            self.com, self.vcom, self.acom = data.com[0], data.vcom[0], data.acom[0]
            self.M, self.nle = data.M, data.nle

    def frame(self, model: pin.Model, fid: int) -> FrameArrays:
        """The :class:`FrameArrays` of frame ``fid`` of ``model`` (this ``data``'s model)."""
        got = self.frames.get(fid)
        if got is None:
            got = self.frames[fid] = FrameArrays.of(model, self.data, fid)
        return got
