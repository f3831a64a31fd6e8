"""The first-run notice: shown only when kernel loading is slow, with its duration."""

from __future__ import annotations

import io
import time

from wbc.runner.compile_notice import CompileNotice


def test_notice_appears_only_when_loading_outlasts_its_delay():
    slow, fast = io.StringIO(), io.StringIO()
    n = CompileNotice(delay=0.05, stream=slow)
    n.start()
    time.sleep(0.3)                    # a compile
    n.stop()
    assert "compiling numerical kernels" in slow.getvalue() and "kernels ready after" in slow.getvalue()
    m = CompileNotice(delay=5.0, stream=fast)
    m.start()
    m.stop()                           # a cached load
    assert fast.getvalue() == "" and not m.shown


def test_disabled_notice_stays_silent():
    out = io.StringIO()
    n = CompileNotice(enabled=False, delay=0.01, stream=out)
    n.start()
    time.sleep(0.1)
    n.stop()
    assert out.getvalue() == ""
