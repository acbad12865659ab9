"""rockjax.jsonio: one cleaning rule for JSON output, and atomic writes."""

import json
import math

import jax.numpy as jnp
import numpy as np
import pytest

from rockjax import jsonio


def test_jsonable_cleans_arrays_scalars_and_non_finite():
    obj = {
        1: np.array([1.0, np.nan, np.inf]),
        "t": (np.int64(3), np.float32(0.5), np.bool_(True)),
        "j": jnp.asarray([[2.0, -np.inf]]),
        "s": "text",
        "n": None,
        "f": -math.inf,
    }
    out = jsonio.jsonable(obj)
    assert out == {
        "1": [1.0, None, None],
        "t": [3, 0.5, True],
        "j": [[2.0, None]],
        "s": "text",
        "n": None,
        "f": None,
    }
    assert type(out["t"][0]) is int and type(out["t"][2]) is bool
    json.dumps(out, allow_nan=False)  # strict JSON


def test_dumps_matches_json_on_plain_data():
    """Plain data (what campaign manifests hold) is written exactly as json.dumps writes it, so
    an unchanged manifest is recognised as unchanged."""
    data = {"b": [1, 2.5, "x"], "a": {"z": None, "y": True}}
    assert jsonio.dumps(data, indent=1, sort_keys=True) == json.dumps(
        data, indent=1, sort_keys=True
    )


def test_write_json_is_whole_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "r.json"
    jsonio.write_json(path, {"x": np.array([1.0, np.nan])})
    assert json.loads(path.read_text()) == {"x": [1.0, None]}
    assert path.read_text().endswith("}\n")
    with pytest.raises(TypeError):  # an object JSON cannot hold: nothing is written
        jsonio.write_json(tmp_path / "bad.json", {"x": object()})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]
