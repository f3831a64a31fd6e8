"""The ``wbc`` command: :func:`~wbc.cli.main.main` and its sub-commands (``run``, ``validate``,
``examples``, ``robot init``/``robots``, ``bench``, ``sweep``) and the exit statuses
(:mod:`~wbc.cli.exits`).

May import: anything in wbc; nothing in wbc imports it."""
