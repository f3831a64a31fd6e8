"""Scenario YAMLs -> objects: :func:`~wbc.scenario.loader.load_config` and
:class:`~wbc.scenario.loader.Scenario`, their sections, events and contacts, building tasks
and stacks from YAML (:mod:`~wbc.scenario.build_tasks`), the bundled examples.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.robot`, :mod:`wbc.tasks`,
:mod:`wbc.stack`, :mod:`wbc.trajectories`, :mod:`wbc.interaction`, :mod:`wbc.sim`,
:mod:`wbc.solvers` (back-end names), :mod:`wbc.controller` (solver names), :mod:`wbc.locomotion`
(the ``walk:`` section). Not the runner or the CLI."""
