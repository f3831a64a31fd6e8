"""Talos sways its centre of mass ±5 cm sideways at 0.5 Hz on its two feet.

Four levels: dynamics, contacts and limits / CoM / torso orientation / posture (strict HQP).
Watch the contact-force arrows shift from foot to foot and the CoM's ground projection
stay inside the support polygon.

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/talos_balance.html (a self-contained replay) and printing its path.

    python demos/talos_balance.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("talos_balance", __doc__))
