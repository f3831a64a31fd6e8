"""``wbc run`` with the live browser view: the viser page (:mod:`wbc.viz.live`,
:mod:`wbc.viz.controls`) on a drawing thread, the control loop paced to real time and taking the
page's commands (:func:`wbc.runner.interactive.run_live`); a ``--record`` replay alongside
(Meshcat, :class:`wbc.viz.Scene`, as a run observer that only keeps frames)."""

from __future__ import annotations

import sys
from dataclasses import dataclass

from wbc.options import Options
from wbc.runner.interactive import Mailbox, run_live
from wbc.runner.options import RunOptions


@dataclass(frozen=True)
class ViewOptions(Options):
    """How ``wbc run`` serves its live page."""

    host: str = "127.0.0.1"
    """the page's address (127.0.0.1 unless asked)"""
    port: int = 8080
    """its port (the next free one from there)"""
    fps: float = 30.0
    """frames drawn per wall second, and snapshots per simulated second"""
    speed: float = 1.0
    """initial speed, × real time"""
    wait: bool = False
    """start the run once a browser has connected"""
    keep: bool = False
    """after the run, keep serving the page (and the last state) until Ctrl-C / Enter"""


def run_with_view(sc, options: RunOptions, view_options: ViewOptions | None = None, on_ready=None,
                  **settings) -> dict:
    """Serve the page, run ``sc`` live (``options``: the run's), return its metrics.

    Args:
        sc: the scenario.
        options: the run's options (a recording's observer in ``callback``, if any).
        view_options: the page's :class:`ViewOptions` (None: its defaults).
        on_ready: called with the view once it serves (tests: the URL, the mailbox).
        **settings: :class:`ViewOptions` fields one by one (``host``, ``port``, ``fps``,
            ``speed``, ``wait``, ``keep``), over ``view_options``.
    """
    o = ViewOptions.of(view_options, settings, "run_with_view")
    host, port, fps, speed, wait, keep = o.host, o.port, o.fps, o.speed, o.wait, o.keep
    from wbc.viz.controls import Controls
    from wbc.viz.live import LiveView

    view = LiveView(sc.robot, sc.environment, host=host, port=port, fps=fps)
    try:
        mailbox = Mailbox()
        view.controls = Controls(view, sc.stack, mailbox, frames=tuple(sc.robot.frames), speed=speed)
        view.mailbox = mailbox
        print(f"wbc: browser view at {view.url}  (Ctrl-C to stop)", flush=True)
        if on_ready is not None:
            on_ready(view)
        if wait:
            print("wbc: waiting for a browser to connect (--wait)", flush=True)
            view.wait_for_client()
        metrics = run_live(sc, options, view.publish, mailbox, fps=fps, speed=speed)
        # the drawing thread's own cost: frames drawn and the wall time each took (ms), in this process
        metrics["live_view"] = {"frames_drawn": view.frames_drawn, "commands": mailbox.posted,
                                "draw_ms_mean": 1e3 * view.draw_seconds / max(view.frames_drawn, 1)}
        if keep:
            print("wbc: run finished; the page keeps the last state (--keep): Enter or Ctrl-C to stop", flush=True)
            try:
                if sys.stdin.isatty():
                    input()
                else:
                    import threading

                    threading.Event().wait()
            except (EOFError, KeyboardInterrupt):
                print()
        return metrics
    finally:
        view.close()
