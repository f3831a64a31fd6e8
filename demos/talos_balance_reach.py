"""Talos balances on its two feet while both hands reach targets 30 cm away.

Closed loop: the wbc controller (strict HQP) drives a pinocchio simulation with
rigid frictional foot contacts at 1 kHz. Prints the run's metrics. With --viz (or
a display) it plays live in the browser (viser, 127.0.0.1: drag the targets, change
gains, pause, push) with the priority diagnostics; otherwise it runs headless and writes a self-contained HTML replay to
recordings/talos_balance_reach.html. This is `make demo`.

    python demos/talos_balance_reach.py [--viz] [--solver hqp|projection|weighted] [--duration S]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("talos_reach", __doc__, name="talos_balance_reach", duration=4.0))
