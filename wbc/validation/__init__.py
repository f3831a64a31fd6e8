"""Plain-data checks, free of any wbc concept: YAML values (:mod:`~wbc.validation.schema`),
YAML documents with line numbers (:mod:`~wbc.validation.yamlio`) and the Python-side input
checks of tasks and chapter controllers (:mod:`~wbc.validation.inputs`), each raising the
typed errors of :mod:`wbc.errors`.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`) only (so the tasks can check values without loading scenarios)."""
