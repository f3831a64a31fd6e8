"""The robot: :class:`~wbc.robot.model.RobotModel` (pinocchio model, data and the per-cycle
cache), finding and loading bundled or user robot YAMLs (:mod:`~wbc.robot.loader`), their
schema (:mod:`~wbc.robot.schema`) and extras beyond the URDF (:mod:`~wbc.robot.extras`),
joint friction/armature compensation, the automatic task gains, and pinocchio's arrays as views
held once for compiled task rows (:mod:`~wbc.robot.held_views`).

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`. Nothing of the tasks, the controller or
the scenario (the gains name :class:`~wbc.tasks.base.Task` only for type checking)."""
