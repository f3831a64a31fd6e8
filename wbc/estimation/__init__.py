"""State and force estimation from proprioception (no force sensor).

:mod:`.momentum_observer`: the generalised-momentum observer of the external joint
torques τ_ext and their projection to a frame's wrench.
"""

from .momentum_observer import MomentumObserver, ObserverError

__all__ = ["MomentumObserver", "ObserverError"]
