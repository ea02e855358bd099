"""The shipped ONNX policies against the numpy forward pass of the same network."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.files.paths import policies_dir
from grasp_ctrl.policy_tools import icra19_net
from grasp_ctrl.policy_tools.convert_icra19 import random_inputs, scaled_error

ort = pytest.importorskip("onnxruntime")

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "official_icra19"
CASES = [("icra19_official", "icra19_weights.npz"), ("icra19_dropout_official", "ll4ma_lab_dropout_weights.npz")]


def _weights(npz: str) -> icra19_net.Icra19Weights:
    if not (DATA / npz).is_file():
        pytest.skip(f"{DATA / npz} not available")
    return icra19_net.load_weights(DATA / npz)


def _session(name: str):  # type: ignore[no-untyped-def]
    return ort.InferenceSession(str(policies_dir() / f"{name}.onnx"), providers=["CPUExecutionProvider"])


@pytest.mark.parametrize("name,npz", CASES)
def test_shipped_onnx_matches_numpy_forward(name: str, npz: str) -> None:
    w = _weights(npz)
    import json

    meta = json.loads((policies_dir() / f"{name}.json").read_text())
    masks = icra19_net.dropout_masks(meta["dropout"]["mask_seed"]) if w.dropout else None
    el, cp = random_inputs(128, seed=7)
    outs = _session(name).run(None, {"electrode_voxels": el, "contact_voxels": cp})
    ref_f, ref_v = icra19_net.forward(w, el, cp, masks)
    assert scaled_error(outs[0], ref_f) < 1e-5
    assert np.max(np.abs(outs[0] - ref_f)) < 1e-4  # N, forces up to ~10 N here
    if w.dropout:
        assert scaled_error(outs[1], ref_v) < 1e-5
        heads = outs[2]
        assert np.allclose(heads.mean(axis=1), outs[0], atol=1e-6)
        assert np.allclose(heads.var(axis=1), outs[1], atol=1e-5)


def _slow_conv(x: np.ndarray, w: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Loop-based channels-last conv, kernel 2 stride 2 (checks the einsum one)."""
    n, *sp, _ = x.shape
    out_sp = [s // 2 for s in sp]
    y = np.zeros((n, *out_sp, w.shape[-1]))
    for idx in np.ndindex(*out_sp):
        sl = tuple(slice(2 * i, 2 * i + 2) for i in idx)
        patch = x[(slice(None),) + sl]  # (n, 2, 2, 2, c)
        y[(slice(None),) + idx] = (
            np.tensordot(patch, w, axes=(list(range(1, len(sp) + 2)), list(range(len(sp) + 1)))) + b
        )
    return y


def test_numpy_conv_matches_a_loop_reference() -> None:
    rng = np.random.default_rng(0)
    x3, w3, b3 = rng.normal(size=(2, 8, 8, 4, 5)), rng.normal(size=(2, 2, 2, 5, 6)), rng.normal(size=6)
    assert np.allclose(icra19_net._conv_k2s2(x3, w3, b3), _slow_conv(x3, w3, b3))
    x2, w2, b2 = rng.normal(size=(3, 2, 2, 4)), rng.normal(size=(2, 2, 4, 7)), rng.normal(size=7)
    assert np.allclose(icra19_net._conv_k2s2(x2, w2, b2), _slow_conv(x2, w2, b2))


def test_layer_norm_is_over_all_non_batch_axes() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(3.0, 2.0, size=(4, 3, 3, 5))
    y = icra19_net._layer_norm_relu(x, np.ones(5), np.zeros(5) + 10.0)  # beta keeps everything > 0
    z = y - 10.0
    assert np.allclose(z.reshape(4, -1).mean(axis=1), 0.0, atol=1e-9)
    assert np.allclose(z.reshape(4, -1).std(axis=1), 1.0, atol=1e-6)


@pytest.mark.parametrize("name,npz", CASES)
def test_converter_reproduces_the_shipped_policy(tmp_path: Path, name: str, npz: str) -> None:
    pytest.importorskip("onnx")
    from grasp_ctrl.policy_tools.convert_icra19 import convert

    _weights(npz)
    onnx_path, json_path, err = convert(DATA / npz, tmp_path, name)
    assert err < 1e-5
    el, cp = random_inputs(16, seed=3)
    fresh = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    a = fresh.run(None, {"electrode_voxels": el, "contact_voxels": cp})[0]
    b = _session(name).run(None, {"electrode_voxels": el, "contact_voxels": cp})[0]
    assert np.array_equal(a, b)
