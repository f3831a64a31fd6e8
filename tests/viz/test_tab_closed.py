"""A tab closed mid-run, in headless Chromium (issue #25, "a browser that disconnects mid-run"):
the run finishes its duration with its metrics, and the drawing process's stderr (inherited
from ``wbc run``'s) holds no traceback.

Before the page, one TCP connection to the server closed before sending anything: what a
browser's spare connection (Chromium's preconnect) does when its tab closes, and what made
``websockets`` log an "opening handshake failed" traceback (:mod:`wbc.viz.viser_quiet`); a
real tab closing does it only now and then.

Skipped with a reason when Chromium (Debian package ``chromium``) or viser is absent.
"""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .test_browser import CHROMIUM, _kill, launch_devtools
from .test_live_view import _close_tab, _new_tab

pytestmark = pytest.mark.browser
ROOT = Path(__file__).resolve().parents[2]
PORT = 8240
DURATION = 3.0      # s simulated


def _wait_for(path: Path, pattern: str, proc: subprocess.Popen, timeout: float) -> re.Match | None:
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end and proc.poll() is None:
        m = re.search(pattern, path.read_text())
        if m:
            return m
        time.sleep(0.1)
    return re.search(pattern, path.read_text())


def test_a_tab_closed_mid_run_leaves_the_metrics_and_no_traceback(tmp_path):
    if CHROMIUM is None:
        pytest.skip("headless Chromium not installed (apt-get install chromium)")
    pytest.importorskip("viser", reason="the live view needs viser")
    out, err, metrics = tmp_path / "out.txt", tmp_path / "err.txt", tmp_path / "metrics.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    with open(out, "w") as fo, open(err, "w") as fe:
        run = subprocess.Popen([sys.executable, "-m", "wbc.cli", "run", "tiago_reach", "--duration", str(DURATION),
                                "--wait", "--port", str(PORT), "--metrics", str(metrics)],
                               cwd=tmp_path, env=env, stdout=fo, stderr=fe)
    chromium = None
    try:
        url = _wait_for(out, r"browser view at (\S+)", run, 120)
        assert url, f"the live view did not start: {err.read_text()[-2000:]}"
        socket.create_connection(("127.0.0.1", PORT), timeout=10).close()     # a spare connection, unused
        chromium, port = launch_devtools(CHROMIUM, "about:blank", tmp_path)
        tab = _new_tab(port, url.group(1))
        assert _wait_for(err, r"t =\s+0\.50 s", run, 300), "the run did not start (the page never drew?)"
        _close_tab(port, tab)                   # mid-run
        run.wait(timeout=300)
    finally:
        if chromium is not None:
            _kill(chromium)
        if run.poll() is None:
            run.kill()
            run.wait()
    stderr = err.read_text()
    print(stderr[-1500:])
    assert run.returncode == 0, stderr[-2000:]
    assert "Traceback" not in stderr
    m = json.loads(metrics.read_text())
    assert m["duration"] == pytest.approx(DURATION, abs=1e-3)
    assert m["solver_failures"] == 0 and not m["fell"]
    assert m["live_view"]["frames_drawn"] > 0
