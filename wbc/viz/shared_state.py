"""The latest state, from the control process to the drawing process, through shared memory.

One slot (:class:`SharedSlot`, ``multiprocessing.shared_memory``) under a sequence lock: the
control loop (the only writer) makes the sequence number odd, copies the encoded snapshot's bytes
and their CRC-32, makes it even again; nothing waits, a write is a few µs for a few kB. The
drawing process (the only reader) copies the bytes out when the number is even and new, and keeps
them only if the number did not move meanwhile and the CRC matches (a write that overlapped the
read: it takes the next one). Older states are never queued: the reader draws the latest.

The header's other words are the drawing process's own counters (it writes them, the control
process reads them): frames drawn, wall time spent drawing (ns), browsers connected (that have
drawn the scene), the drawing process's CPU time (ns), the control process's messages it has
applied.
"""

from __future__ import annotations

import zlib
from multiprocessing import shared_memory

import numpy as np

from ..errors import WbcError

HEADER_WORDS = 16
HEADER_BYTES = 8 * HEADER_WORDS
SEQ, LENGTH, CRC, FRAMES, DRAW_NS, CLIENTS, CPU_NS, DRAW_MAX_NS, HANDLED = range(9)
CAPACITY = 1 << 20         # bytes: one encoded snapshot (a few kB for a humanoid)


class SharedSlot:
    """A sequence-locked slot of ``capacity`` bytes; ``name`` None creates it (the control
    process, which unlinks it in :meth:`close`), else attaches to that one (the drawing process)."""

    def __init__(self, name: str | None = None, capacity: int = CAPACITY) -> None:
        self.owner = name is None
        if self.owner:
            self.shm = shared_memory.SharedMemory(create=True, size=HEADER_BYTES + capacity)
        else:
            try:        # Python ≥ 3.13: the creator alone tracks (and unlinks) the block
                self.shm = shared_memory.SharedMemory(name=name, track=False)     # type: ignore[call-arg]
            except TypeError:
                self.shm = shared_memory.SharedMemory(name=name)
        self.name = self.shm.name
        self.capacity = self.shm.size - HEADER_BYTES
        buf = self.shm.buf
        assert buf is not None, "an open shared-memory block"
        self.header = np.ndarray((HEADER_WORDS,), np.int64, buf, 0)
        if self.owner:
            self.header[:] = 0
        self._data = buf[HEADER_BYTES:]
        self._seen = 0

    # ------------------------------------------------------------------ writer (control loop)
    def write(self, payload: bytes) -> None:
        """Store ``payload`` as the latest state (never waits)."""
        n = len(payload)
        if n > self.capacity:
            raise WbcError(f"live view: an encoded snapshot of {n} bytes exceeds the shared slot's {self.capacity}")
        h = self.header
        h[SEQ] += 1                     # odd: being written
        self._data[:n] = payload
        h[LENGTH] = n
        h[CRC] = zlib.crc32(payload)
        h[SEQ] += 1                     # even: complete

    # ------------------------------------------------------------------ reader (drawing process)
    def read_new(self) -> bytes | None:
        """The latest payload if complete and not read before, else None."""
        h = self.header
        seq = int(h[SEQ])
        if seq == self._seen or seq & 1:
            return None
        n, crc = int(h[LENGTH]), int(h[CRC])
        payload = bytes(self._data[:n])
        if int(h[SEQ]) != seq or zlib.crc32(payload) != crc:
            return None                 # overwritten while copied: the next call takes the new one
        self._seen = seq
        return payload

    def set_stats(self, frames: int, draw_ns: int, draw_max_ns: int, clients: int, cpu_ns: int,
                  handled: int = 0) -> None:
        """The drawing process's counters (module docstring)."""
        h = self.header
        h[FRAMES], h[DRAW_NS], h[DRAW_MAX_NS], h[CLIENTS], h[CPU_NS] = frames, draw_ns, draw_max_ns, clients, cpu_ns
        h[HANDLED] = handled

    @property
    def writes(self) -> int:
        """Payloads written so far."""
        return int(self.header[SEQ]) // 2

    def close(self) -> None:
        """Release this process's mapping (and remove the block, for its creator)."""
        del self.header
        self._data.release()
        self.shm.close()
        if self.owner:
            try:
                self.shm.unlink()
            except FileNotFoundError:
                pass
