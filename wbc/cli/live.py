"""``wbc run`` with the live browser view: the viser page (:mod:`wbc.viz.live`,
:mod:`wbc.viz.drawing`, :mod:`wbc.viz.controls`) drawn by a process of its own, the control loop paced to real time and taking the
page's commands (:func:`wbc.runner.interactive.run_live`); a ``--record`` replay alongside
(Meshcat, :class:`wbc.viz.Scene`, as a run observer that only keeps frames)."""

from __future__ import annotations

import sys
from dataclasses import dataclass

from wbc.runner.interactive import Mailbox, run_live
from wbc.runner.options import RunOptions
from wbc.viz.live import PageOptions


@dataclass(frozen=True)
class ViewOptions(PageOptions):
    """How ``wbc run`` serves its live page: the page's :class:`~wbc.viz.live.PageOptions`
    (``host``, ``port``, ``fps``, ``speed``, …) and when the run starts and ends."""

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
    fps, speed, wait, keep = o.fps, o.speed, o.wait, o.keep
    import time

    from wbc.viz import shown_frames
    from wbc.viz.live import LiveView
    from wbc.viz.run_overlays import overlay_data, overlay_names

    view = LiveView(sc.robot, sc.environment, sc.stack, o, frames=tuple(sc.robot.frames),
                    shown_frames=shown_frames(sc), overlays=overlay_names(sc))
    try:
        mailbox = Mailbox(feed=view.drain)
        view.mailbox = mailbox
        print(f"wbc: browser view at {view.url}  (Ctrl-C to stop)", flush=True)
        if on_ready is not None:
            on_ready(view)
        if wait:
            print("wbc: waiting for a browser to connect and draw the scene (--wait)", flush=True)
            view.wait_for_client()
        cpu0 = time.process_time()
        metrics = run_live(sc, options, view.publish, mailbox, fps=fps, speed=speed, extras=overlay_data)
        # the drawing process's cost (frames drawn, wall time per frame, its CPU time) and this
        # process's (CPU time of the run, publish time per snapshot)
        metrics["live_view"] = {**view.stats(), "commands": mailbox.posted, "page_commands": view.page_commands,
                                "control_cpu_s": time.process_time() - cpu0}
        if keep:
            print("wbc: run finished; the page keeps the last state (--keep): Enter or Ctrl-C to stop", flush=True)
            import threading

            done = threading.Event()

            def discard() -> None:      # the page's commands after the run: read (the pipe never fills), dropped
                box = Mailbox()
                while not done.wait(0.1):
                    view.drain(box)
                    box.take()

            threading.Thread(target=discard, daemon=True).start()
            try:
                if sys.stdin.isatty():
                    input()
                else:
                    threading.Event().wait()
            except (EOFError, KeyboardInterrupt):
                print()
            done.set()
        return metrics
    finally:
        view.close()
