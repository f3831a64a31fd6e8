"""The `wbc` command line: complete help, a headless run's summary, plot errors."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from wbc.cli.main import build_parser, main

ROOT = Path(__file__).resolve().parents[2]
OWN = ("run", "plot", "validate", "examples", "robots", "tasks")      # `bench` documents itself (wbc/cli/bench.py)


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_top_level_help_lists_every_command_with_a_description(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for cmd in (*OWN, "bench"):
        assert f"\n    {cmd} " in out, f"`wbc --help` does not describe {cmd}"
    assert "examples:" in out


@pytest.mark.parametrize("cmd", OWN)
def test_every_option_of_every_command_is_described(cmd):
    sub = _subparsers(build_parser())[cmd]
    assert sub.description and len(sub.description) > 40
    for action in sub._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        assert action.help and len(action.help) > 10, f"wbc {cmd}: {action.dest} has no help"
        if action.option_strings and action.default not in (None, False) and not isinstance(action.default, bool):
            assert "default" in action.help, f"wbc {cmd} {action.option_strings[0]}: default not stated"


def test_run_help_states_units(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    for needle in ("--duration S", "in s", "--plot FILE.png", "--series", "--diagnostics-rate HZ", "127.0.0.1"):
        assert needle in out


def test_headless_run_prints_the_metrics_summary(capsys):
    code = main(["run", str(ROOT / "wbc" / "data" / "scenarios" / "talos_balance.yaml"), "--headless", "--duration", "0.05"])
    out = capsys.readouterr().out
    metrics = json.loads(out[out.index("{"):])
    assert code == 0
    assert metrics["scenario"] == "talos_balance" and metrics["duration"] == pytest.approx(0.05)
    assert "series" not in metrics                        # time series only when asked


def test_metrics_keep_series_only_with_series_flag(tmp_path):
    js, png = tmp_path / "m.json", tmp_path / "m.png"
    assert main(["run", str(ROOT / "wbc" / "data" / "scenarios" / "talos_balance.yaml"), "--headless", "--duration", "0.02",
                 "--metrics", str(js), "--plot", str(png)]) == 0
    assert png.is_file()
    assert "series" not in json.loads(js.read_text())     # plotted, not kept
    assert main(["plot", str(js)]) == 2                   # so `wbc plot` says how to get them


def test_tasks_lists_parameters_with_units(capsys):
    assert main(["tasks"]) == 0
    out = capsys.readouterr().out
    assert "kp = 100.0" in out and "1/s²" in out and "fmin = 0.0" in out and ", N" in out


def test_bundled_scenario_runs_by_name_from_any_directory(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)                            # no tasks/ folder here
    assert main(["validate", "talos_balance"]) == 0
    assert main(["run", "talos_balance", "--headless", "--duration", "0.02"]) == 0
    assert main(["validate", "no_such_scenario"]) == 2
    err = capsys.readouterr().err
    assert "no_such_scenario" in err and "talos_balance" in err   # names the choices


def test_examples_lists_and_copies_the_bundled_scenarios(tmp_path, capsys):
    from wbc.scenario.examples import available_scenarios

    assert main(["examples"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in available_scenarios())
    assert main(["examples", str(tmp_path / "mine")]) == 0
    copied = sorted(p.stem for p in (tmp_path / "mine").glob("*.yaml"))
    assert copied == available_scenarios() and "talos_balance" in copied
    assert main(["validate", str(tmp_path / "mine" / "talos_balance.yaml")]) == 0
