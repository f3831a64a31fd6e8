"""Forward-dynamics simulation: rigid unilateral Coulomb contacts, pushes, sensing.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.robot` (types). Not the controller or the scenario.
"""

from .bodies import Push, box_model
from .environment import Box, HalfSpace, ground, incline
from .simulator import Simulator

__all__ = ["Simulator", "Push", "HalfSpace", "Box", "ground", "incline", "box_model"]
