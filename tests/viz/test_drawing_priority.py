"""The live view's drawing process yields the CPU to the control loop: :func:`wbc.viz.drawing.lower_priority`
raises its nice value and, since the drawing process is a session of its own, its session's autogroup's
(with ``kernel.sched_autogroup_enabled`` a process's nice value only orders the processes of its session:
without the autogroup's, the scheduler shares the CPU equally between the drawing process and the loop).
Run in a child that starts its own session, as :class:`wbc.viz.live.LiveView` starts the drawing process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHILD = """
import os
from wbc.viz.drawing import lower_priority
before = open("/proc/self/autogroup").read().split()[-1]
lower_priority(7)
print(before, os.nice(0), open("/proc/self/autogroup").read().split()[-1])
"""


@pytest.mark.skipif(not Path("/proc/self/autogroup").exists(), reason="no scheduler autogroups on this system")
def test_the_drawing_process_lowers_its_session_group_too():
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, check=True, timeout=120,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), start_new_session=True).stdout.split()
    before, nice, group = map(int, out)
    assert nice == min(os.nice(0) + 7, 19)          # the process's own nice value
    assert before == 0 and group == 7          # its new session's autogroup (nice 0 at creation), niced too
