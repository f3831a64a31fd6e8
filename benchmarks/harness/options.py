"""The bench's defaults, owned by the harness: the ``wbc bench`` options the package parses
(:func:`wbc.cli.bench.add_parser`) default to None, and :func:`benchmarks.harness.cli.bench`
fills them in from here."""

#: the QP back-ends the cases run hqp and weighted with (``--backends``' default)
BACKENDS = ("daqp", "proxqp", "quadprog", "osqp")
#: timed cycles per case (``--cycles``' default)
DEFAULT_CYCLES = 2000
#: wall-time budget (s) per case, without and with ``--quick`` (``--budget``' default)
FULL_BUDGET, QUICK_BUDGET = 180.0, 2.5
