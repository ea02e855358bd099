"""BioTac model parameters from a JSON file (``biotac-anchors --params``)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.sim.biotac.model import DEFAULT_PARAMS, N_GAIN, pack_params, rise_weights_of, static_frames
from grasp_ctrl.sim.biotac.params_file import load_biotac_params

RISE_FIT = Path(__file__).resolve().parents[2] / "docs" / "biotac_params_rise_fit.json"


def _write(tmp_path: Path, doc: object) -> Path:
    path = tmp_path / "params.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def _pad_frames(params) -> np.ndarray:
    rng = np.random.default_rng(0)
    n = 50
    x = rng.uniform(-0.012, 0.004, n)
    angle = rng.uniform(-1.0, 1.0, n)
    radius = 5.5e-3
    points = np.stack([x, radius * np.sin(angle), -radius * np.cos(angle)], axis=1)
    normals = np.stack([np.zeros(n), np.sin(angle), -np.cos(angle)], axis=1)
    f = -normals * rng.uniform(0.3, 4.0, n)[:, None] + rng.normal(0.0, 0.2, (n, 3))
    return static_frames(points, normals, f, np.ones((n, N_GAIN)), pack_params(params))


def test_the_side_weight_and_the_same_weights_given_per_electrode_give_the_same_frames():
    explicit = replace(DEFAULT_PARAMS, rise_weights=tuple(rise_weights_of(DEFAULT_PARAMS)))
    np.testing.assert_array_equal(_pad_frames(DEFAULT_PARAMS), _pad_frames(explicit))


def test_rise_weights_change_only_the_free_skin_rise():
    doubled = replace(DEFAULT_PARAMS, rise_weights=tuple(2.0 * rise_weights_of(DEFAULT_PARAMS)))
    before, after = _pad_frames(DEFAULT_PARAMS), _pad_frames(doubled)
    np.testing.assert_array_equal(before[:, 19], after[:, 19])  # pdc untouched
    assert np.any(after[:, :19] > before[:, :19] + 5.0)  # some electrodes rise more


def test_the_shipped_fit_loads(tmp_path):
    params = load_biotac_params(RISE_FIT)
    assert params.rise_weights is not None and len(params.rise_weights) == 19
    assert params.e_drop_gain != DEFAULT_PARAMS.e_drop_gain
    # the file's own form and a {"params": ...} wrapper read the same
    wrapped = _write(tmp_path, {"params": json.loads(RISE_FIT.read_text(encoding="utf-8"))})
    assert load_biotac_params(wrapped) == params


def test_an_empty_object_is_the_default_model(tmp_path):
    assert load_biotac_params(_write(tmp_path, {})) == DEFAULT_PARAMS


@pytest.mark.parametrize(
    "doc, field",
    [
        ({"no_such_field": 1.0}, "no_such_field"),
        ({"pdc_gain": "high"}, "pdc_gain"),
        ({"pdc_gain": True}, "pdc_gain"),
        ({"e_baseline_range": [3000.0]}, "e_baseline_range"),
        ({"rise_weights": [1.0] * 18}, "rise_weights"),
        ({"rise_weights": [1.0] * 18 + [-1.0]}, "rise_weights"),
        ({"rise_weights": 2.0}, "rise_weights"),
        ([1, 2], "JSON object"),
    ],
)
def test_bad_files_are_refused_naming_the_field(tmp_path, doc, field):
    with pytest.raises(ValueError, match=field):
        load_biotac_params(_write(tmp_path, doc))


def test_unreadable_and_non_json_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load_biotac_params(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    with pytest.raises(ValueError, match="not JSON"):
        load_biotac_params(bad)


def test_the_anchor_command_refuses_a_bad_params_file_in_one_line(tmp_path, capsys):
    from grasp_ctrl.cli import main

    bad = _write(tmp_path, {"rise_weights": [1.0, 2.0]})
    assert main(["biotac-anchors", "--data", str(tmp_path / "unused.csv"), "--params", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--params" in err[0] and "rise_weights" in err[0]
