"""The progress line of ``wbc run``: redrawn in place on a terminal, plain lines in a log or pipe."""

from __future__ import annotations

from wbc.runner.loop import run
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config


def test_progress_to_a_pipe_is_plain_short_lines(capsys):
    """pytest's captured stderr is not a terminal: no carriage return, one line per report
    (every 500 cycles and the last), each a line a log reader can read."""
    run(load_config(SCENARIOS_DIR / "talos_balance.yaml"), duration=1.2, progress=True)
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = [line for line in err.splitlines() if "real-time factor" in line]
    assert len(lines) == 4                      # cycles 0, 500, 1000 and the last (1199)
    assert all(len(line) < 120 for line in err.splitlines())
