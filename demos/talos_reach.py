"""Talos reaches two hand targets (one low, one high) while balancing.

The hands' level cannot be fully served under the CoM level: the diagnostics panel shows
which tasks are sacrificed and the rank left to each level.

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/talos_reach.html (a self-contained replay) and printing its path.

    python demos/talos_reach.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("talos_reach", __doc__))
