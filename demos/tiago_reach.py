"""TIAGo reaches a hand target 1.5 m ahead and 0.6 m aside: base and arm move together.

The differential-drive constraint (no lateral base velocity) is a hard level-0 row.

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/tiago_reach.html (a self-contained replay) and printing its path.

    python demos/tiago_reach.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("tiago_reach", __doc__))
