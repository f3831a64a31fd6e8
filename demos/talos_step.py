"""Talos shifts its weight, lifts the right foot 5 cm and puts it down 10 cm forward.

Contact switches are force-ramped (release / touch-down events): the right foot's force arrows
fade out before lift-off and back in after touch-down, with continuous torques.

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/talos_step.html (a self-contained replay) and printing its path.

    python demos/talos_step.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("talos_step", __doc__))
