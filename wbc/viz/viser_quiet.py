"""A browser's connection closed before it sent a request: no traceback on the drawing
process's stderr.

A browser opens spare TCP connections next to the ones it uses (Chromium's preconnects) and
closes them unused, e.g. when its tab closes. viser's server (on ``websockets``) reads each
connection's HTTP request line; on an empty one, ``websockets.asyncio.server`` logs "opening
handshake failed" on the ``websockets.server`` logger with the exception (an ``EOFError``
chained under ``InvalidMessage``): a traceback with no frame of wbc on its stack. viser 1.1.1
filters that message itself, but installs its filter from its HTTP handler, at the first
request the server has *processed*: a spare connection closed before then prints the traceback
(a raw socket opened and closed on a fresh server always does).

:func:`quiet_closed_handshakes` installs, before the server starts, a filter for exactly that
record: the message "opening handshake failed" with an ``EOFError`` in its exception's chain
(the peer closed the connection before its request line). Any other handshake failure (a
malformed request, a timeout) and every other record still reach the log.
"""

from __future__ import annotations

import logging

LOGGER = "websockets.server"
MESSAGE = "opening handshake failed"


def _closed_by_peer(exc: BaseException | None) -> bool:
    """``exc`` or an exception it was raised from / during is an ``EOFError``."""
    seen = 0
    while exc is not None and seen < 10:
        if isinstance(exc, EOFError):
            return True
        exc = exc.__cause__ or exc.__context__
        seen += 1
    return False


class ClosedHandshakeFilter(logging.Filter):
    """Drops "opening handshake failed" records whose exception is a connection the peer closed
    before its request; counts them in ``dropped``."""

    def __init__(self) -> None:
        super().__init__()
        self.dropped = 0

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if record.getMessage() == MESSAGE and _closed_by_peer(exc):
            self.dropped += 1
            return False
        return True


def quiet_closed_handshakes() -> ClosedHandshakeFilter:
    """Install (once per process) the filter on the ``websockets.server`` logger; returns it."""
    logger = logging.getLogger(LOGGER)
    for f in logger.filters:
        if isinstance(f, ClosedHandshakeFilter):
            return f
    f = ClosedHandshakeFilter()
    logger.addFilter(f)
    return f
