"""`wbc run --plot` and `wbc plot`: a short quiet-balance run, its time series and its figure.

The series must be consistent (one sample per control cycle in every array) and
physically sensible: standing still on two feet, the contact normal forces carry
the robot's weight (Σ F_n ≈ m g), every contact force stays inside its friction
cone, torques stay within their limits and the hard level is satisfied."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from wbc.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
DURATION = 0.6      # s simulated: the sway's ramp-in, the robot quietly standing


@pytest.fixture(scope="module")
def balance_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("plot")
    png, js = d / "balance.png", d / "balance.json"
    code = main(["run", str(ROOT / "wbc" / "data" / "scenarios" / "talos_balance.yaml"), "--headless",
                 "--duration", str(DURATION),
                 "--series", "--metrics", str(js), "--plot", str(png)])
    assert code == 0
    return d, png, json.loads(js.read_text())


def test_plot_is_a_png_of_the_expected_size(balance_run):
    from PIL import Image

    _, png, _ = balance_run
    with Image.open(png) as img:
        img.verify()
    with Image.open(png) as img:
        assert img.format == "PNG"
        assert img.size == (1200, 800)
        px = np.asarray(img.convert("L"), dtype=float)
    assert px.std() > 10.0          # not a blank canvas: axes, lines and text were drawn


def test_series_has_one_sample_per_control_cycle_in_every_array(balance_run):
    _, _, m = balance_run
    s = m["series"]
    n = round(DURATION / s["dt"])
    t = np.array(s["t"])
    assert len(t) == n
    assert np.allclose(np.diff(t), s["dt"])
    arrays = [*s["task_errors"].values(), s["torque"]["ratio_max"], *s["torque"]["joints"].values(),
              s["support_margin"]]
    for c in s["contacts"].values():
        arrays += [c["normal_force"], c["friction_margin"]]
    assert {len(a) for a in arrays} == {n}
    # the solver's per-level diagnostics: sampled every few cycles, on their own clock
    tl = np.array(s["level_t"])
    assert 0 < len(tl) < n and np.all(np.diff(tl) > 0) and tl[-1] <= t[-1]
    assert {len(a) for a in (*s["level_residual"], *s["level_rank"], *s["level_sigma_min"])} == {len(tl)}
    assert set(s["task_errors"]) == {"com", "torso", "posture"}
    # the scenario's 4 levels and the contact regularisation the controller adds below them
    assert len(s["level_residual"]) == len(s["levels"]) == 5
    assert s["levels"][-1] == ["contact_regularization"]


def test_series_is_physically_sensible_in_quiet_balance(balance_run):
    _, _, m = balance_run
    s = m["series"]
    mg = s["mass"] * s["g"]
    fn = np.array([c["normal_force"] for c in s["contacts"].values()])
    total = fn.sum(axis=0)[10:]                          # after the first contact settling cycles
    print(f"Σ F_n / m g: mean {total.mean() / mg:.4f}, range [{total.min() / mg:.4f}, {total.max() / mg:.4f}]")
    assert abs(total.mean() / mg - 1.0) < 0.02
    assert np.all(np.abs(total / mg - 1.0) < 0.10)
    assert np.all(fn[:, 10:] > 0.3 * mg / 2)              # both feet loaded
    margins = np.array([c["friction_margin"] for c in s["contacts"].values()])
    assert np.all(margins > 0.0)                         # inside the friction cones
    ratio = np.array(s["torque"]["ratio_max"])
    assert np.all((ratio >= 0.0) & (ratio <= 1.0 + 1e-6))
    assert max(s["torque"]["peak_ratio"].values()) == pytest.approx(ratio.max(), rel=1e-3)
    assert np.nanmax(s["level_residual"][0]) < 1e-6      # hard level satisfied
    com = np.array(s["task_errors"]["com"])
    assert com.max() < 0.01                              # m
    assert np.nanmin(s["support_margin"]) > 0.02         # CoM well inside the feet


def test_wbc_plot_replots_a_saved_run(balance_run, tmp_path):
    from PIL import Image

    d, _, _ = balance_run
    out = tmp_path / "again.png"
    assert main(["plot", str(d / "balance.json"), "-o", str(out), "--width", "900", "--height", "600"]) == 0
    with Image.open(out) as img:
        assert img.size == (900, 600)


def test_wbc_plot_without_series_exits_2_and_says_how(tmp_path, capsys):
    js = tmp_path / "m.json"
    js.write_text(json.dumps({"scenario": "x", "fell": False}))
    assert main(["plot", str(js)]) == 2
    assert "--series" in capsys.readouterr().err
    assert main(["plot", str(tmp_path / "missing.json")]) == 2
