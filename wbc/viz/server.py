"""The Meshcat server of a :class:`~wbc.viz.Scene`, its web page bound to one address.

meshcat 0.3.2's ``meshcat-server`` binds its zmq socket to 127.0.0.1 but its web server
(tornado's ``app.listen(port)``, no address) to every interface, IPv4 and IPv6, whatever
URL it prints. This one binds the page (HTTP and the viewer's websocket) to ``host`` only,
127.0.0.1 unless asked (``wbc run --host``), and the zmq socket, through which this process
sends the scene, to 127.0.0.1 always: another machine may watch the page, never draw.

:func:`start` runs this file as a script (``python -u server.py --host H``), which imports
meshcat only; the script prints ``zmq_url=...`` and ``web_url=...`` as meshcat's does.
"""

from __future__ import annotations

import argparse
import atexit
import socket
import subprocess
import sys
import tempfile

DEFAULT_HOST = "127.0.0.1"


def start(host: str = DEFAULT_HOST) -> tuple[subprocess.Popen, str, str]:
    """Start a server whose page listens on ``host`` (an IP address or name of this machine);
    returns (its process, zmq URL, web URL). Raises :class:`~wbc.errors.WbcError` if it
    cannot listen there."""
    from ..errors import WbcError

    log = tempfile.TemporaryFile()      # its stderr (tornado's log): a pipe nobody reads would fill
    proc = subprocess.Popen([sys.executable, "-u", __file__, "--host", host], stdout=subprocess.PIPE,
                            stderr=log, start_new_session=True)
    assert proc.stdout is not None, "stdout=PIPE"
    urls: dict[str, str] = {}
    while len(urls) < 2:
        line = proc.stdout.readline().decode("utf-8", "replace").strip()
        if not line and proc.poll() is not None:
            proc.stdout.close()
            log.seek(0)
            err = log.read().decode("utf-8", "replace").strip().splitlines()
            raise WbcError(f"the Meshcat server could not listen on {host!r}: {err[-1] if err else 'no output'}")
        key, _, value = line.partition("=")
        if key in ("zmq_url", "web_url"):
            urls[key] = value
    log.close()                         # unlinked already: the server keeps writing to it
    atexit.register(stop, proc)
    return proc, urls["zmq_url"], urls["web_url"]


def stop(proc: subprocess.Popen) -> None:
    """End a server :func:`start` started (SIGTERM, then SIGKILL after 5 s)."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    if proc.stdout is not None:
        proc.stdout.close()


def main(argv: list[str] | None = None) -> None:
    args = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args.add_argument("--host", default=DEFAULT_HOST)
    host = args.parse_args(argv).host
    try:            # an address this machine does not have: say so, not "no port free" 1000 ports later
        family = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)[0][0]
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.bind((host, 0))
    except OSError as exc:
        sys.exit(f"{exc}")
    import warnings

    with warnings.catch_warnings():     # as in wbc/viz/meshcat_quiet.py (a script run by path: no package)
        warnings.filterwarnings("ignore", "zmq.eventloop.ioloop is deprecated", DeprecationWarning)
        from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class Bridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **kw: listen(port, address=host, **kw)     # not every interface
            return app

    bridge = Bridge(host=DEFAULT_HOST)         # the zmq socket: this machine's processes only
    shown = f"[{host}]" if ":" in host else host
    bridge.web_url = f"http://{shown}:{bridge.fileserver_port}/static/"
    print(f"zmq_url={bridge.zmq_url}")
    print(f"web_url={bridge.web_url}")
    bridge.run()


if __name__ == "__main__":
    main()
