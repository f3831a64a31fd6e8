"""Every code block of README.md runs: the Python blocks as written, each `wbc ...` line of
the shell blocks through the command's own entry point (runs shortened to 0.05 s and made
headless, in a scratch directory so that one line's output feeds the next)."""

from __future__ import annotations

import importlib.util
import re
import shlex
from pathlib import Path

import pytest

from wbc.cli.main import main

README = Path(__file__).resolve().parents[2] / "README.md"
BLOCK = re.compile(r"^```(\w+)\n(.*?)^```", re.S | re.M)
#: shell lines the test does not run: set-up commands (the Makefile and pip are CI's job)
SETUP = ("make ", "pip ", "python ", ". ", "PYTHON=")


def _blocks(lang: str) -> list[str]:
    return [body for kind, body in BLOCK.findall(README.read_text()) if kind == lang]


def test_readme_has_the_two_commands_first():
    first = _blocks("sh")[0].splitlines()
    assert [line.split()[:2] for line in first] == [["make", "demo"], ["make", "test"]]


@pytest.mark.parametrize("k", range(len(_blocks("python"))))
def test_readme_python_block_runs(k, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(_blocks("python")[k], f"README.md python block {k}", "exec"), {"__name__": "__readme__"})


def _commands() -> list[list[str]]:
    out = []
    for body in _blocks("sh"):
        for line in body.splitlines():
            line = line.split("  #")[0].strip()
            if not line or line.startswith(SETUP):
                continue
            assert line.startswith("wbc "), f"README shell line the test does not know how to run: {line!r}"
            out.append(shlex.split(line)[1:])
    return out


def test_readme_shell_lines_run(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    cmds = _commands()
    assert len(cmds) >= 10
    root = README.parent
    for argv in cmds:
        if "mujoco" in argv and importlib.util.find_spec("mujoco") is None:
            continue                                  # the optional [mujoco] extra
        # files the README names in the repository (benchmarks/...), from the scratch directory
        argv = [str(root / a) if a.startswith("benchmarks/") else a for a in argv]
        if argv[:1] == ["--help"] or argv[-1:] == ["--help"]:
            with pytest.raises(SystemExit) as exc:
                main(argv)
            assert exc.value.code == 0
            continue
        if argv[0] == "bench":
            continue                                  # minutes long; tests/bench/test_bench.py runs it
        if argv[0] == "run":
            argv = [a for a in argv if a != "--headless"]
            if "--duration" in argv:
                i = argv.index("--duration")
                del argv[i:i + 2]
            argv += ["--headless", "--duration", "0.05"]
        assert main(argv) == 0, f"README: `wbc {shlex.join(argv)}` failed: {capsys.readouterr().err[-2000:]}"
