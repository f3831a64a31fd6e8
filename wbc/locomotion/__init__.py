"""Walking: footstep plans, their timing, the CoM reference from the LIPM and the swing-foot
trajectories, and (issue #24) the planning a walking run needs.

- :mod:`~wbc.locomotion.footsteps`: footstep plans from poses or a command (v_x, v_y, ω), limits.
- :mod:`~wbc.locomotion.timing`: the phases (double/single support) of a plan and its ZMP reference.
- :mod:`~wbc.locomotion.preview`: ZMP preview control on the LIPM (Kajita 2003), replanned from the
  measured CoM and DCM.
- :mod:`~wbc.locomotion.swing`: quintic swing-foot trajectories.
- :mod:`~wbc.locomotion.plan`: a walk's footsteps and phases, changed in its future at run time.
- :mod:`~wbc.locomotion.walker`: the run-time walker (CoM replanning, swing foot, contact
  switching through the controller's force ramps, touch-down detection).
- :mod:`~wbc.locomotion.walk_metrics`: a walk's figures from the simulator's state and forces.

May import :mod:`wbc.errors` (and :mod:`wbc.options`) and :mod:`wbc.tasks` (the swing foot's Frame task); the
controller it is given is used through its ``release_contact``/``make_contact``.
"""
