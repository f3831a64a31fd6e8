"""Fuzz at the text level: bundled scenario and robot files edited as text (random unicode,
lines dropped, duplicated or replaced, YAML tags, deep nesting, alias bombs, invalid UTF-8,
huge literals, tabs, extra documents). Each either loads or is refused with a WbcError
naming the file and a key path or a line; nothing else, and never an unsafe YAML tag.
"""

from __future__ import annotations

import os
import tempfile
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import wbc
from wbc.errors import WbcError
from wbc.robot.loader import ROBOTS_DIR
from wbc.scenario.examples import SCENARIOS_DIR
from wbc.scenario.loader import load_config

from .conftest import SLOW_FACTOR

DEFAULT_CASES = 300
#: a file the inserted python tags would create if the loader ever constructed them
MARKER = Path(tempfile.gettempdir()) / f"wbc-yaml-fuzz-{os.getpid()}-tag-was-constructed"
FILES = [(p, "scenario") for p in sorted(SCENARIOS_DIR.glob("*.yaml"))] + \
        [(p, "robot") for p in sorted(ROBOTS_DIR.glob("*.yaml"))]


def _bomb(depth: int) -> str:
    lines = ["&a0 [1.0, 1.0]"]
    for i in range(1, depth):
        lines.append(f"&a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}]")
    return "[" + ", ".join(lines) + "]"


INSERTS = st.one_of(
    st.text(max_size=30),
    st.sampled_from([
        f"!!python/object/apply:os.system ['touch {MARKER}']", f"!!python/object/apply:pathlib.Path.touch ['{MARKER}']",
        "!!python/name:os.system", "!!python/object:wbc.Stack {}",
        "!!python/tuple [1, 2]", "!!binary aGVsbG8=", "!!set {a, b}", "!!omap [a: 1]", "!ruby/object {}",
        "2001-13-45", "1" * 5000, "1.0e+99999", "-.inf", ".nan", "0o777", "0x_1F", "1:20:30", "~", "&x *x",
        "*undefined_alias", "\t- 1", "{a: 1, a: 2}", "[1, 2", "? [a, b]\n: c", "'unterminated", "<<: *nope",
        "\x00", "\ufeff", "---\nanother: doc", "...", "%YAML 1.1", "|\n  block", "\u2028", "{{{{", "- - - -",
    ]),
    st.integers(10, 1200).map(lambda d: "[" * d + "1" + "]" * d),
    st.integers(3, 14).map(_bomb),
)


@st.composite
def edited(draw):
    path, kind = draw(st.sampled_from(FILES))
    lines = path.read_text().splitlines()
    how = draw(st.sampled_from(["insert", "replace_value", "drop_line", "dup_line", "replace_line", "bytes"]))
    i = draw(st.integers(0, len(lines) - 1))
    if how == "insert":
        col = draw(st.integers(0, len(lines[i])))
        lines[i] = lines[i][:col] + draw(INSERTS) + lines[i][col:]
    elif how == "replace_value":
        idx = [k for k, ln in enumerate(lines) if ":" in ln and not ln.lstrip().startswith("#")]
        i = draw(st.sampled_from(idx))
        head = lines[i][: lines[i].index(":") + 1]
        lines[i] = f"{head} {draw(INSERTS)}"
    elif how == "drop_line":
        del lines[i]
    elif how == "dup_line":
        lines.insert(i, lines[i])
    elif how == "replace_line":
        lines[i] = draw(INSERTS)
    data = "\n".join(lines).encode("utf-8", errors="surrogatepass")
    if how == "bytes":
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.sampled_from([b"\xff", b"\xc3\x28", b"\x80\x80", b"\xed\xa0\x80"])) + data[at:]
    return path.stem, kind, data, how


def check_text(tmp_path, name: str, kind: str, data: bytes, stats: Counter) -> str:
    f = tmp_path / (name + ".yaml")
    f.write_bytes(data)
    MARKER.unlink(missing_ok=True)
    try:
        if kind == "scenario":
            load_config(f, robot_loader=wbc.load_robot)
        else:
            wbc.load_robot(f)
    except WbcError as exc:
        msg = str(exc)
        assert msg.startswith(str(f)), f"does not name the file first: {msg}"
        assert exc.key or exc.line, f"names neither a key nor a line: {msg}"
        assert "Traceback" not in msg and len(msg) < 3000, msg
        stats["error with line" if exc.line else "error with key"] += 1
        return "error"
    finally:
        assert not MARKER.exists(), "a python tag was constructed"
    return "valid"


def _fuzz(tmp_path, n_cases: int, profile: str) -> Counter:
    stats: Counter = Counter()

    @settings(settings.get_profile(profile), max_examples=n_cases)
    @given(case=edited())
    def check(case):
        name, kind, data, how = case
        stats[check_text(tmp_path, name, kind, data, stats)] += 1
        stats["cases"] += 1

    check()
    return stats


def test_text_edited_yaml_files_load_or_name_file_and_line(tmp_path, capsys):
    stats = _fuzz(tmp_path, DEFAULT_CASES, "wbc-default")
    print(f"\nYAML text fuzz: {stats['cases']} cases, {stats['valid']} still valid, {stats['error']} WbcErrors "
          f"({stats['error with line']} with a line), 0 other exceptions")
    assert stats["cases"] >= DEFAULT_CASES * 0.95
    assert stats["error"] > 0.3 * stats["cases"] and stats["valid"] > 0.05 * stats["cases"]


@pytest.mark.slow
def test_text_edited_yaml_files_many_more_random_cases(tmp_path):
    stats = _fuzz(tmp_path, DEFAULT_CASES * SLOW_FACTOR, "wbc-slow")
    assert stats["cases"] >= DEFAULT_CASES * SLOW_FACTOR * 0.95
