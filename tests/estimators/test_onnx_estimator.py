"""Loading ONNX policies (metadata checks) and batched estimation."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import copy_policy

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.sensor_layout import ELECTRODES, PDC
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.estimators.pipeline import TactilePipeline
from grasp_ctrl.estimators.registry import load_policy
from grasp_ctrl.files.paths import default_hand_file

pytest.importorskip("onnxruntime")


def _pressed(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.zeros((n, 44))
    t[:, ELECTRODES] = -rng.uniform(0, 300, (n, 19)) * (rng.random((n, 19)) < 0.5)
    t[:, PDC] = rng.uniform(20, 400, n)
    return t


@pytest.mark.parametrize("name", ["icra19_official", "icra19_dropout_official"])
def test_batched_call_equals_one_by_one(name: str) -> None:
    est = load_policy(name, load_hand(default_hand_file()), threads=1)
    tared = _pressed(5)
    batch = est.estimate(tared, ["a"] * 5)
    assert batch.f_sensor.shape == (5, 3)
    for i in range(5):
        one = est.estimate(tared[i : i + 1], ["a"])
        assert np.allclose(one.f_sensor, batch.f_sensor[i], atol=1e-5)
    assert (batch.variance is not None) == (name == "icra19_dropout_official") == est.has_variance
    if batch.variance is not None:
        assert (batch.variance >= 0).all()
    empty = est.estimate(np.zeros((0, 44)), [])
    assert empty.f_sensor.shape == (0, 3)


def test_pad_press_gives_f_sensor_along_plus_z() -> None:
    """docs/design.md 4: a press on the pad gives f_sensor mostly along +z (sign converted)."""
    est = load_policy("icra19_official", threads=1)
    t = np.zeros((1, 44))
    t[0, 16:19] = -250.0  # e17..e19, the pad's centre line
    t[0, PDC] = 300.0
    f = est.estimate(t, ["index"]).f_sensor[0]
    assert f[2] > 0 and f[2] > abs(f[1])


def test_threads_are_configurable() -> None:
    est = load_policy("icra19_official", threads=2)
    assert est.session.get_session_options().intra_op_num_threads == 2
    with pytest.raises(PolicyError, match="threads"):
        load_policy("icra19_official", threads=0)


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda m: m.update(sensor_type="digit"), "sensor_type"),
        (lambda m: m["input"].update(kind="raw_frames"), "input.kind"),
        (lambda m: m["preprocessing"].update(tare="baseline - value"), "preprocessing.tare"),
        (lambda m: m["preprocessing"].update(voxel_grid="fancy"), "preprocessing.voxel_grid"),
        (lambda m: m["preprocessing"].pop("contact_point"), "preprocessing.contact_point: required key is missing"),
        (lambda m: m["output"].update(units="kN"), "output.units"),
        (lambda m: m["output"].update(frame="hand"), "output.frame"),
        (lambda m: m["output"].update(to_f_sensor=2), "output.to_f_sensor"),
        (lambda m: m.update(has_variance=True), "has_variance is true but no variance output"),
        (lambda m: m["output"].update(tensors={"forces": {}}), "'forces' is not an output of the ONNX model"),
        (
            lambda m: m["input"].update(
                tensors={"electrode_voxels": {"shape": ["batch", 16, 16, 8]}, "cpt": {"shape": ["batch", 16, 16, 8]}}
            ),
            "'cpt' is not an input",
        ),
        (lambda m: m["input"]["tensors"]["contact_voxels"].update(shape=["batch", 12, 12, 8]), "shape"),
        (lambda m: m.update(model_file="missing.onnx"), "model_file"),
    ],
)
def test_metadata_mismatch_is_a_clear_policy_error(
    tmp_path: Path, edit: Callable[[dict[str, Any]], None], message: str
) -> None:
    path = copy_policy(tmp_path, edit)
    with pytest.raises(PolicyError, match=message) as info:
        load_policy(str(path), load_hand(default_hand_file()), threads=1)
    assert str(path.name) in str(info.value) or "missing.onnx" in str(info.value)


def test_corrupt_model_file_is_a_policy_error(tmp_path: Path) -> None:
    # the hash matches (so onnxruntime gets to parse it), the content is not a model
    bad = b"not a model"
    path = copy_policy(tmp_path, lambda m: m.update(model_sha256=hashlib.sha256(bad).hexdigest()))
    (tmp_path / "icra19_official.onnx").write_bytes(bad)
    with pytest.raises(PolicyError, match="cannot load the ONNX model"):
        load_policy(str(path), threads=1)


def test_pipeline_runs_the_network_only_for_tips_in_contact() -> None:
    est = load_policy("icra19_dropout_official", threads=1)
    calls: list[int] = []
    real = est.estimate

    def spy(tared: np.ndarray, fingers: list[str]):  # type: ignore[no-untyped-def]
        calls.append(len(fingers))
        return real(tared, fingers)

    est.estimate = spy  # type: ignore[method-assign]
    fingers = ["index", "middle", "ring", "thumb"]
    pipe = TactilePipeline(est, fingers, threshold=10.0, frames=3)
    base = np.full((20, 4, 44), 2000.0)
    pipe.set_baseline(base)
    frame = np.full((4, 44), 2000.0)
    frame[1, ELECTRODES] -= 200.0
    frame[1, PDC] += 150.0  # only the middle fingertip is pressed
    outs = [pipe.step(frame) for _ in range(4)]
    assert [o.in_contact.tolist() for o in outs][:3] == [[False] * 4] * 2 + [[False, True, False, False]]
    assert calls == [1, 1]  # one batched call per tick once the gate opened, with only that tip
    last = outs[-1]
    assert np.all(last.f_sensor[[0, 2, 3]] == 0) and np.linalg.norm(last.f_sensor[1]) > 0
    assert last.variance is not None and np.all(last.variance[[0, 2, 3]] == 0)
