"""`wbc`'s exit statuses (0 ok, 1 fell or controller failed, 2 bad input, 3 internal error),
tracebacks only with --debug, and the YAML reader's refusals (tags, duplicate keys, deep
nesting, bad bytes) with the file and the line."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import wbc
import wbc.runner.loop
import wbc.scenario.loader
from wbc.cli.main import main
from wbc.validation.yamlio import read_document

ROOT = Path(__file__).resolve().parents[2]
BALANCE = ROOT / "wbc" / "data" / "scenarios" / "talos_balance.yaml"


def _boom(*args, **kwargs):
    raise ZeroDivisionError("injected fault")


@pytest.mark.parametrize("where,argv", [
    ("wbc.scenario.loader.load_config", ["validate", str(BALANCE)]),
    ("wbc.scenario.loader.load_config", ["run", str(BALANCE), "--headless", "--duration", "0.002"]),
    ("wbc.runner.loop.run", ["run", str(BALANCE), "--headless", "--duration", "0.002"]),
])
def test_an_internal_error_exits_3_with_a_short_message_and_no_traceback(monkeypatch, capsys, where, argv):
    module, name = where.rsplit(".", 1)
    monkeypatch.setattr(f"{module}.{name}", _boom)
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert f"internal error in `wbc {argv[0]}`: ZeroDivisionError: injected fault" in err
    assert "please report it with --debug output" in err and f"wbc --debug {argv[0]}" in err
    assert "Traceback" not in err and "_boom" not in err


def test_debug_prints_the_traceback_of_an_internal_error(monkeypatch, capsys):
    monkeypatch.setattr("wbc.scenario.loader.load_config", _boom)
    assert main(["--debug", "validate", str(BALANCE)]) == 3
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "in _boom" in err
    assert "ZeroDivisionError: injected fault" in err and "internal error" in err


def test_debug_also_shows_where_a_bad_input_error_was_raised(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BALANCE.read_text().replace("kp: 100.0", "kp: fast"))
    assert main(["validate", str(bad)]) == 2
    plain = capsys.readouterr().err
    assert "Traceback" not in plain
    assert main(["--debug", "validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and err.endswith(plain)


def test_a_robot_that_falls_exits_1(tmp_path, capsys):
    """A 4 kN push at the torso topples Talos within 0.1 s: the run ends early, exit 1."""
    sc = tmp_path / "fall.yaml"
    sc.write_text("robot: talos\nduration: 1.0\nstack:\n"
                  "  - [{type: contact, contact: left_foot}, {type: contact, contact: right_foot}]\n"
                  "  - [{type: com, kp: 100.0}]\n"
                  "pushes: [{frame: torso, force: [4000.0, 0.0, 0.0], start: 0.0, duration: 0.3}]\n")
    assert main(["validate", str(sc)]) == 0
    assert main(["run", str(sc), "--headless"]) == 1
    out = capsys.readouterr().out
    assert '"fell": true' in out


def test_solver_failures_exit_1(monkeypatch, capsys):
    real = wbc.runner.loop.run

    def failing(*args, **kwargs):
        metrics = real(*args, **kwargs)
        metrics["solver_failures"] = 3
        return metrics

    monkeypatch.setattr("wbc.runner.loop.run", failing)
    assert main(["run", str(BALANCE), "--headless", "--duration", "0.003"]) == 1


def test_a_good_run_exits_0_and_bad_input_2(tmp_path, capsys):
    assert main(["run", str(BALANCE), "--headless", "--duration", "0.003"]) == 0
    assert main(["validate", str(tmp_path / "missing.yaml")]) == 2
    assert "missing.yaml: file not found" in capsys.readouterr().err


# ------------------------------------------------------------------ the YAML reader
@pytest.mark.parametrize("tag", ["!!python/object/apply:os.system ['touch {marker}']",
                                 "!!python/object:wbc.stack.Stack {{}}", "!!python/name:os.system"])
def test_python_tags_are_refused_and_never_constructed(tmp_path, capsys, tag):
    marker = tmp_path / "constructed"
    sc = tmp_path / "tagged.yaml"
    sc.write_text(BALANCE.read_text().replace("description: ", "description: " + tag.format(marker=marker) + " #"))
    with pytest.raises(wbc.ConfigError) as info:
        wbc.load_config(sc)
    msg = str(info.value)
    assert msg.startswith(f"{sc}:2: the YAML tag 'tag:yaml.org,2002:python/"), msg
    assert "is not allowed: wbc reads plain YAML only" in msg
    assert main(["validate", str(sc)]) == 2 and "Traceback" not in capsys.readouterr().err
    assert not marker.exists()


def test_a_python_tag_in_a_robot_yaml_is_refused(tmp_path):
    robot = tmp_path / "talos.yaml"
    text = (ROOT / "wbc" / "data" / "robots" / "talos.yaml").read_text()
    robot.write_text(text.replace("name: talos", "name: !!python/name:os.getcwd"))
    with pytest.raises(wbc.RobotDefinitionError, match=r"talos.yaml:2: the YAML tag .*python/name:os.getcwd.* not "
                                                      r"allowed"):
        wbc.load_robot(robot)


def test_duplicate_keys_are_refused_with_both_lines(tmp_path):
    sc = tmp_path / "dup.yaml"
    sc.write_text(BALANCE.read_text().replace("duration: 10.0", "duration: 10.0\nduration: 2.0"))
    with pytest.raises(wbc.ConfigError, match=r"dup.yaml:7: duplicate key 'duration' \(first given on line 6\)"):
        wbc.load_config(sc)


def test_merge_keys_may_be_overridden(tmp_path):
    f = tmp_path / "merge.yaml"
    f.write_text("base: &b {kp: 1.0, kd: 2.0}\ntask: {<<: *b, kp: 3.0}\n")
    assert read_document(f).data["task"] == {"kp": 3.0, "kd": 2.0}


def test_deep_nesting_and_bad_bytes_are_refused_with_the_line(tmp_path):
    deep = tmp_path / "deep.yaml"
    deep.write_text(BALANCE.read_text().replace("kp: 100.0", "kp: " + "[" * 200 + "1" + "]" * 200))
    with pytest.raises(wbc.ConfigError,
                       match=r"deep.yaml:15: stack\[1\]\[0\]\.kp\[0\]\[0\]\[0\]\[0\]\.\.\.: lists and mappings nested "
                             r"more than 50 deep"):
        wbc.load_config(deep)
    deep.write_text(BALANCE.read_text().replace("kp: 100.0", "kp: " + "[" * 50_000 + "1" + "]" * 50_000))
    with pytest.raises(wbc.ConfigError, match=r"deep.yaml:15: (stack\[1\]\[0\]\.kp.*: lists and mappings nested"
                                             r"|not valid YAML: exceeded)"):
        wbc.load_config(deep)       # libyaml, when PyYAML has it, stops at 1000 levels itself
    raw = tmp_path / "raw.yaml"
    raw.write_bytes(BALANCE.read_bytes().replace(b"kp: 100.0", b"kp: \xff\xfe"))
    with pytest.raises(wbc.ConfigError, match=r"raw.yaml:15: not UTF-8 text"):
        wbc.load_config(raw)
    huge = tmp_path / "huge.yaml"
    huge.write_text(BALANCE.read_text().replace("kp: 100.0", "kp: " + "9" * 5000))
    with pytest.raises(wbc.ConfigError, match=r"huge.yaml:15: a value YAML cannot convert: .*digits"):
        wbc.load_config(huge)
    date = tmp_path / "date.yaml"
    date.write_text(BALANCE.read_text().replace("duration: 10.0", "duration: 0000-01-01"))
    with pytest.raises(wbc.ConfigError, match=r"date.yaml:6: a value YAML cannot convert: year 0 is out of range"):
        wbc.load_config(date)


def test_a_name_too_long_for_the_file_system_is_an_unknown_robot_or_scenario(tmp_path, capsys):
    """`robot: <5000 characters>` raised OSError (File name too long) from Path.is_file."""
    sc = tmp_path / "long.yaml"
    sc.write_text(BALANCE.read_text().replace("robot: talos", "robot: " + "t" * 5000))
    assert main(["validate", str(sc)]) == 2
    err = capsys.readouterr().err
    assert re.search(r"long.yaml:3: robot: unknown robot 'tttt.*\.\.\..*tttt': expected one of \[", err), err
    assert len(err) < 400
    assert main(["validate", "s" * 5000]) == 2 and "no such scenario file" in capsys.readouterr().err


def test_an_alias_bomb_is_refused_fast(tmp_path):
    """Nested aliases (a billion laughs) where a number is expected: refused at the first item."""
    bomb = "[" + ", ".join(["&a0 [1.0, 1.0]"] + [f"&a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}]"
                                                  for i in range(1, 25)]) + "]"
    sc = tmp_path / "bomb.yaml"
    sc.write_text(BALANCE.read_text().replace("kp: 100.0", f"kp: {bomb}"))
    with pytest.raises(wbc.ConfigError, match=r"bomb.yaml:15: stack\[1\]\[0\]\.kp: must be a number"):
        wbc.load_config(sc)


def test_lines_are_recorded_per_key_path():
    doc = read_document(BALANCE)
    assert doc.line("stack[1][0].kp") == 15 and doc.line("stack[1][0].trajectory.amplitude[2]") == 16
    assert doc.line("environment[0].mu") == 8 and doc.line("control.dt") == 5
    assert doc.line("stack[1][0].no_such_key") == 14        # the nearest enclosing key path's line


def test_a_simulator_that_is_not_installed_is_refused_by_validate(tmp_path, monkeypatch, capsys):
    """`simulator: mujoco` without the mujoco package: refused when validating, not mid-run."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "mujoco" else real(name, *a))
    sc = tmp_path / "mj.yaml"
    sc.write_text(BALANCE.read_text() + "simulator: mujoco\n")
    assert main(["validate", str(sc)]) == 2
    assert re.search(r"mj.yaml:19: simulator: needs the mujoco package", capsys.readouterr().err)
