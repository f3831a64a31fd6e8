"""Talos takes a 150 N, 0.1 s push at the torso and recovers with its feet planted.

The push arrow shows while it acts; compare --solver hqp (recovers) with --solver projection.

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/talos_push.html (a self-contained replay) and printing its path.

    python demos/talos_push.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("talos_push", __doc__))
