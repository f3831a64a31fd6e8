"""The shared-memory slot between the control and the drawing process (wbc.viz.shared_state): the
reader gets the latest complete payload once, never a payload being written, never a torn one."""

from __future__ import annotations

import pytest

from wbc.errors import WbcError
from wbc.viz import shared_state as ss


def test_latest_payload_read_once_and_never_mid_write():
    writer = ss.SharedSlot(capacity=64)
    reader = ss.SharedSlot(writer.name)
    try:
        assert reader.read_new() is None                    # nothing written yet
        writer.write(b"first")
        writer.write(b"second")
        assert reader.read_new() == b"second"               # the latest, not a queue
        assert reader.read_new() is None                    # read once
        writer.header[ss.SEQ] += 1                          # a write begun (sequence number odd)
        writer._data[:6] = b"third!"
        assert reader.read_new() is None
        writer.header[ss.LENGTH] = 6
        writer.header[ss.SEQ] += 1                          # complete, but its CRC is the old one's
        assert reader.read_new() is None                    # a torn payload is refused
        writer.write(b"fourth")
        assert reader.read_new() == b"fourth" and writer.writes == 4      # the torn one counted
        with pytest.raises(WbcError, match="exceeds the shared slot's 64"):
            writer.write(b"x" * 65)
        reader.set_stats(3, 4, 5, 1, 6, 7)
        assert writer.header[ss.FRAMES] == 3 and writer.header[ss.CLIENTS] == 1 and writer.header[ss.HANDLED] == 7
    finally:
        reader.close()
        writer.close()
