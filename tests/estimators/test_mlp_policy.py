"""The default policy ``mlp_mock``: a small MLP run in numpy, fitted on presses anywhere a
grasp's contact lands on the simulated skin (the mock world's default skin contact)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.registry import DEFAULT_POLICY, load_policy
from grasp_ctrl.files.paths import policies_dir
from grasp_ctrl.sim.biotac.presses import pad_presses, skin_presses


def _angles_deg(pred: np.ndarray, f: np.ndarray) -> np.ndarray:
    cos = np.sum(pred * f, axis=1) / (np.linalg.norm(pred, axis=1) * np.linalg.norm(f, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def test_the_default_policy_reads_presses_anywhere_on_the_skin_where_a_linear_fit_cannot(hand):
    assert DEFAULT_POLICY == "mlp_mock"
    tared, f = skin_presses(1500, 123)  # seed unused by the fit (seeds 0 and 2)
    mlp = _angles_deg(load_policy("mlp_mock", hand).estimate(tared, []).f_sensor, f)
    linear = _angles_deg(load_policy("linear_mock", hand).estimate(tared, []).f_sensor, f)
    assert np.median(mlp) < 5.0 and np.median(linear) > 15.0  # measured: 3.1 and 36 deg
    pad_tared, pad_f = pad_presses(500, 321)
    assert np.median(_angles_deg(load_policy("mlp_mock", hand).estimate(pad_tared, []).f_sensor, pad_f)) < 5.0


def _broken_copy(tmp_path, edit) -> str:
    meta = json.loads((policies_dir() / "mlp_mock.json").read_text())
    edit(meta)
    path = tmp_path / "p.json"
    path.write_text(json.dumps(meta))
    return str(path)


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda m: m.update(input_channels=[0, 1, 99]), "input_channels"),
        (lambda m: m.update(input_channels="all"), "input_channels"),
        (lambda m: m.update(input_mean=m["input_mean"][:5]), "input_mean"),
        (lambda m: m.update(input_scale=[0.0] * 20), "input_scale"),
        (lambda m: m["layers"][0].update(bias=[float("nan")] * 64), r"layers\[0\].bias"),
        (lambda m: m["layers"].pop(), "last layer"),
        (lambda m: m["layers"][1].update(weights=[[1.0] * 3] * 64), r"layers\[1\]"),
        (lambda m: m.update(layers=[]), "layers"),
        (lambda m: m.update(layers=[1, 2]), r"layers\[0\]"),
    ],
)
def test_a_broken_mlp_policy_is_one_policy_error_naming_the_field(tmp_path, hand, edit, field):
    with pytest.raises(PolicyError, match=field):
        load_policy(_broken_copy(tmp_path, edit), hand)


def test_the_mlp_batch_is_the_rows_one_by_one(hand):
    est = load_policy("mlp_mock", hand)
    tared, _ = skin_presses(5, 4)
    together = est.estimate(tared, []).f_sensor
    alone = np.vstack([est.estimate(tared[i : i + 1], []).f_sensor for i in range(5)])
    np.testing.assert_allclose(together, alone, rtol=1e-12, atol=1e-12)
    assert est.estimate(np.zeros((0, 44)), []).f_sensor.shape == (0, 3)


def test_the_mlp_compiled_pass_is_within_1e_9_n_of_numpys(monkeypatch):
    """The compiled forward pass (the path with numba) rounds its sums in another order and
    has its own tanh: within 1e-9 N of the plain numpy pass (measured: 5e-15 N), for one to
    four fingertips' rows, presses on the skin included, and a NaN input stays NaN."""
    import types

    from grasp_ctrl.estimators import mlp

    est = load_policy("mlp_mock")
    rng = np.random.default_rng(9)
    rows = [rng.normal(0.0, 300.0, (k, 44)) for k in (1, 2, 3, 4) for _ in range(25)]
    rows += [skin_presses(4, seed)[0] for seed in range(10)] + [np.zeros((0, 44))]
    broken = rng.normal(0.0, 300.0, (3, 44))
    broken[1, 0] = np.nan
    rows.append(broken)
    fast = [est.estimate(r, ["x"] * len(r)).f_sensor for r in rows]
    monkeypatch.setattr(mlp, "jit", types.SimpleNamespace(JIT=False))
    for r, f in zip(rows, fast):
        plain = est.estimate(r, ["x"] * len(r)).f_sensor
        assert f.shape == plain.shape and f.dtype == np.float64
        assert np.array_equal(np.isnan(f), np.isnan(plain))
        np.testing.assert_allclose(f, plain, rtol=0.0, atol=1e-9)
    assert np.isnan(fast[-1][1]).all() and np.isfinite(fast[-1][[0, 2]]).all()


def test_the_compiled_tanh_is_numpys_to_a_few_ulp_of_one():
    from grasp_ctrl.estimators.mlp import tanh_rows

    x = np.concatenate(
        [
            np.linspace(-25.0, 25.0, 50_001),
            np.geomspace(1e-300, 30.0, 2000),
            -np.geomspace(1e-300, 30.0, 2000),
            [0.0, -0.0, np.inf, -np.inf, np.nan, 1e308, -1e308],
        ]
    )
    h = np.vstack([x, x[::-1]])
    tanh_rows(h, h.shape[1], np.empty_like(h))
    expected = np.tanh(np.vstack([x, x[::-1]]))
    assert np.array_equal(np.isnan(h), np.isnan(expected))
    np.testing.assert_allclose(h, expected, rtol=0.0, atol=4e-16)  # measured: 3.3e-16 (1.5 ulp of 1)
