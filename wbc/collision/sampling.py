"""The self pairs worth monitoring, sampled: the MoveIt setup assistant's method.

Of the default self pairs (:func:`wbc.collision.pairs.default_self_pairs`: all, minus the SRDF's
disabled ones and adjacent links), keep those that come within the influence distance in at
least one of many random configurations inside the joint limits. ``wbc robot collisions ROBOT``
writes the result beside the robot YAML (:func:`wbc.collision.pairs.write_pair_file`).
"""

from __future__ import annotations

import numpy as np

from .model import CollisionModel


def sample_self_pairs(robot, influence: float = 0.05, samples: int = 2000, seed: int = 0) -> tuple[list, dict]:
    """The default pairs that come within ``influence`` (m) in at least one of ``samples``
    random configurations inside the joint limits (seeded); and a summary dict."""
    cm = CollisionModel(robot, self_pairs="default")
    rng = np.random.default_rng(seed)
    data = robot.model.createData()
    closest = np.full(len(cm.pairs), np.inf)
    for _ in range(samples):
        q = robot.random_configuration(rng, margin=0.0)
        closest = np.minimum(closest, cm.all_distances(q, data))
    keep = [(cm.names[a], cm.names[b]) for (a, b), d in zip(cm.pairs, closest) if d < influence]
    return keep, {"candidates": len(cm.pairs), "kept": len(keep), "samples": samples, "influence": influence,
                  "seed": seed}
