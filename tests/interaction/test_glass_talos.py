"""talos_glass (5.3.5): Talos on both feet with a glass in its right hand, 30 N sideways on
the right elbow from 1 s to 2 s. Selective compliance keeps the glass (tilt < 2°, hand
< 1 cm) while the elbow yields (> 3 cm) and the feet hold; one joint impedance everywhere
tilts it (> 10°). Short runs here; the full runs (every solver, the observer's estimate, MuJoCo) are
tests/interaction/test_glass_full.py, marked slow. Also the ``interaction:`` section's and ``protect:``'s input errors."""

from __future__ import annotations

import pytest
import yaml

from tests.helpers.glass_common import TASKS, TEN_DEG, TWO_DEG, assert_clean, check_selective, glass_run
from wbc.errors import ConfigError
from wbc.scenario.loader import load_config

PUSH_END = 2.1      # s: the push acts from 1 s to 2 s


def test_talos_glass_keeps_the_glass_while_the_elbow_yields():
    m = glass_run("talos_glass", duration=PUSH_END)
    check_selective(m, tilt=0.1 * TWO_DEG, hand=1e-3)      # the true push: 0.01°, 0.03 mm measured
    assert m["push_estimate"]["error_rel"] < 0.01           # the observer (feet sensors known), reported


def test_talos_glass_without_selective_compliance_tilts_the_glass():
    m = glass_run("talos_glass_compliant", duration=PUSH_END)
    assert_clean(m)
    assert m["glass_tilt_max"] > TEN_DEG


@pytest.mark.parametrize("edit, key, words", [
    (lambda d: d["interaction"].update(glass="left_hand"), "interaction.glass", "frame task"),
    (lambda d: d["interaction"].update(external_force="sensor"), "interaction.external_force", "observer"),
    (lambda d: d["interaction"].update(observer_gain=-1.0), "interaction.observer_gain", "(0, 10000]"),
    (lambda d: d["interaction"].update(glas="right_hand"), "interaction.glas", "glass"),
    (lambda d: d["interaction"].update(elbow="no_such_frame"), "interaction.elbow", "no frame"),
    (lambda d: d["stack"][3][0].update(protect=["com", "left_hand"]), "stack[3][0].protect", "left_hand"),
    (lambda d: (d["stack"][3][0].pop("zeta"), d["stack"][3][0].update(B_nu=[[1.0, 0.0], [0.0, 1.0]])),
     "stack[3][0].B_nu", "17 × 17"),
    (lambda d: d["stack"][3][0].update(protect="com"), "stack[3][0].protect", "list"),
    (lambda d: d["stack"][3][0].update(B_nu=2.0), "stack[3][0].zeta", "not both"),
])
def test_bad_interaction_input_names_the_key(tmp_path, edit, key, words):
    doc = yaml.safe_load((TASKS / "talos_glass.yaml").read_text())
    edit(doc)
    path = tmp_path / "talos_glass.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert key in str(err.value) and words in str(err.value) and "talos_glass.yaml" in str(err.value)
