"""Walking: footstep plans, their timing, the CoM reference from the LIPM and the swing-foot
trajectories, and (issue #24) the planning a walking run needs.

- :mod:`~wbc.locomotion.footsteps`: footstep plans from poses or a command (v_x, v_y, ω), limits.
- :mod:`~wbc.locomotion.timing`: the phases (double/single support) of a plan and its ZMP reference.
- :mod:`~wbc.locomotion.preview`: ZMP preview control on the LIPM (Kajita 2003), replanned from the
  measured CoM and DCM.
- :mod:`~wbc.locomotion.swing`: quintic swing-foot trajectories.

Plain planning (numpy, scipy): it may import ``wbc.errors`` and nothing else of wbc. The
run-time walker (contact switching through the controller's force ramps) is not built yet
(issue #24).
"""
