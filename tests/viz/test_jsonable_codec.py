"""The live view's snapshot encoding (wbc/viz/jsonable.py): what the control process writes
into the shared slot comes back equal, arrays with their dtype and shape and float64 values
bit for bit, and only as plain data (JSON, never pickle)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wbc import jsonable


def test_a_snapshot_comes_back_equal_with_its_arrays():
    rng = np.random.default_rng(3)
    snap = {"t": 1.25, "q": rng.standard_normal(39), "points": rng.standard_normal((8, 3)),
            "forces": np.zeros((0, 3)), "pushes": [("torso", np.array([30.0, 0.0, 0.0]))],
            "targets": {"right_hand": np.eye(4), "com": np.array([0.0, 0.01, 0.87])},
            "levels": [["joint_limits", "left_foot"], ["com"]], "paused": False, "rtf": float("nan"),
            "overlays": {"collision pairs": {"segments": rng.standard_normal((2, 2, 3)),
                                             "colors": np.array([[255, 0, 0], [0, 255, 0]], np.uint8)}},
            "rows": [{"level": 0, "sigma_min": np.float64(0.25), "sacrificed": None}], "speed": np.float32(0.5)}
    got = jsonable.decode(jsonable.encode(snap))
    assert np.array_equal(got["q"], snap["q"]) and got["q"].dtype == np.float64
    assert got["points"].shape == (8, 3) and got["forces"].shape == (0, 3)
    assert got["pushes"][0][0] == "torso" and np.array_equal(got["pushes"][0][1], [30.0, 0.0, 0.0])
    assert np.array_equal(got["targets"]["right_hand"], np.eye(4))
    seg = got["overlays"]["collision pairs"]
    assert np.array_equal(seg["segments"], snap["overlays"]["collision pairs"]["segments"])
    assert seg["colors"].dtype == np.uint8
    assert got["levels"] == snap["levels"] and got["paused"] is False and np.isnan(got["rtf"])
    assert got["rows"][0]["sigma_min"] == 0.25 and got["speed"] == 0.5
    json.loads(jsonable.encode(snap))            # plain JSON: any reader builds only plain values


def test_a_key_that_is_not_a_string_is_refused():
    with pytest.raises(TypeError, match="must be a string"):
        jsonable.encode({"targets": {3: np.zeros(3)}})
