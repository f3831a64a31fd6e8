"""Talos on both feet holds a glass level; a 30 N push on the elbow for 1 s is absorbed by a compliant null space.

The chapter's scenario (5.3.5) on a humanoid. The push arrow (purple, 2 mm per N, pointing
at the elbow) shows while it acts; the glass's frame is drawn twice: its target's axes
(8 cm) and the hand's actual axes (12 cm), so a tilt shows as the two triads parting.
Compare with wbc/data/scenarios/talos_glass_compliant.yaml (`wbc run talos_glass_compliant`).

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/talos_glass.html (a self-contained replay) and printing its path.

    python demos/talos_glass.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("talos_glass", __doc__))
