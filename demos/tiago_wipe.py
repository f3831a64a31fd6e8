"""TIAGo wipes a table: its hand pad presses with 10 N while sliding 30 cm along it (hybrid force/motion, 5.3.3).

At the pad, two arrows at 1 cm per N: the desired force λ_D (a wide translucent teal
sleeve, rising from 0 over 0.3 s) and the measured force the task's PI uses, λ_m (a thin
pink core inside it); the diagnostics panel gives both in N. The simulator's contact
force at the pad is the orange arrow (1 mm per 2 N).

Live in the browser with --viz (or a display); otherwise headless, writing
recordings/tiago_wipe.html (a self-contained replay) and printing its path.

    python demos/tiago_wipe.py [--viz] [--solver hqp|projection|weighted] [--duration S] [--plot out.png]
"""

import sys

from _run_scenario import main

if __name__ == "__main__":
    sys.exit(main("tiago_wipe", __doc__))
