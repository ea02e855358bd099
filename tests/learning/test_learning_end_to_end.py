"""A tiny train -> evaluate -> export -> fine-tune run through the command line (seconds)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")
ort = pytest.importorskip("onnxruntime")

from grasp_ctrl.cli import main  # noqa: E402


def test_train_evaluate_export_finetune(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    monkeypatch.setenv("GRASP_CTRL_POLICIES", str(tmp_path / "policies"))
    ckpt = tmp_path / "tiny.pt"
    common = ["--synthetic", "250", "--seed", "4", "--test-per-source", "100"]
    assert main(["train", *common, "--arch", "voxel", "--epochs", "2", "--out", str(ckpt), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "mixed" in out and ckpt.is_file()

    assert main(["export", str(ckpt), "--name", "tiny_voxel"]) == 0
    assert (tmp_path / "policies" / "tiny_voxel.onnx").is_file()
    meta = json.loads((tmp_path / "policies" / "tiny_voxel.json").read_text())
    assert meta["kind"] == "onnx" and meta["sensor_type"] == "biotac" and meta["output"]["frame"] == "sensor"
    assert meta["provenance"]["onnx_vs_torch_max_error"] <= 1e-5 and not meta["has_variance"]
    assert list(meta["input"]["tensors"]) == ["electrode_voxels", "contact_voxels"]
    assert "mixed" in meta["metrics"] and meta["training"]["data"]["synthetic_per_source"] == 250
    assert main(["export", str(ckpt), "--name", "tiny_voxel"]) == 2  # no silent overwrite

    # the exported policy and the checkpoint give the same test metrics
    js = tmp_path / "m.json"
    assert main(["evaluate", "tiny_voxel", str(ckpt), *common, "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    a, b = doc["tiny_voxel"]["mixed"], doc[str(ckpt)]["mixed"]
    assert a["angle_deg"]["median"] == pytest.approx(b["angle_deg"]["median"], abs=1e-3)

    # fine-tune from the policy's weights on one source
    ckpt2 = tmp_path / "ft.pt"
    assert (
        main(
            [
                "train",
                *common,
                "--sources",
                "rigid-ft",
                "--arch",
                "voxel",
                "--epochs",
                "1",
                "--init-from",
                "tiny_voxel",
                "--out",
                str(ckpt2),
                "--quiet",
            ]
        )
        == 0
    )
    assert torch.load(ckpt2, weights_only=True)["init_from"] == "tiny_voxel"
    # its policy says where it started; --description replaces the generic text
    assert main(["export", str(ckpt2), "--name", "tiny_ft"]) == 0
    assert json.loads((tmp_path / "policies" / "tiny_ft.json").read_text())["description"].endswith(
        "fine-tuned from tiny_voxel"
    )
    assert main(["export", str(ckpt2), "--name", "tiny_ft2", "--description", "tiny, tuned on rigid-ft"]) == 0
    assert json.loads((tmp_path / "policies" / "tiny_ft2.json").read_text())["description"] == "tiny, tuned on rigid-ft"
    assert main(["train", *common, "--arch", "su", "--epochs", "1", "--init-from", "tiny_voxel", "--quiet"]) == 2
    assert "is a 'voxel' model" in capsys.readouterr().err


def test_dropout_export_has_variance_and_analytic_policy_loads(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setenv("GRASP_CTRL_POLICIES", str(tmp_path))
    common = ["--synthetic", "200", "--seed", "5", "--test-per-source", "100", "--quiet"]
    ckpt = tmp_path / "d.pt"
    assert main(["train", *common, "--arch", "voxel-dropout", "--epochs", "1", "--out", str(ckpt)]) == 0
    assert main(["export", str(ckpt), "--name", "drop"]) == 0
    meta = json.loads((tmp_path / "drop.json").read_text())
    assert meta["has_variance"] and list(meta["output"]["tensors"]) == ["f_sensor", "variance"]
    sess = ort.InferenceSession(str(tmp_path / "drop.onnx"))
    grid = np.zeros((3, 16, 16, 8), np.float32)
    grid[:, 5, 5, 2] = -300
    f, var = sess.run(None, {"electrode_voxels": grid, "contact_voxels": (grid != 0).astype(np.float32)})
    assert f.shape == (3, 3) and var.shape == (3, 3) and np.all(var >= 0)

    an = tmp_path / "an.json"
    assert main(["train", *common, "--arch", "analytic", "--out", str(an)]) == 0
    assert main(["export", str(an), "--name", "an_policy"]) == 0
    from grasp_ctrl.estimators.registry import load_policy

    est = load_policy("an_policy")
    tared = np.zeros((1, 44))
    tared[0, 16:19] = -500.0  # pad electrodes pressed
    assert est.estimate(tared, ["index"]).f_sensor[0, 2] > 0  # pushes into the pad: +z


def test_bad_input_is_one_line(tmp_path: Path, capsys) -> None:
    assert main(["train", "--arch", "voxel"]) == 2
    assert "either --data" in capsys.readouterr().err
    assert main(["train", "--data", str(tmp_path / "nope.csv")]) == 2
    err = capsys.readouterr().err
    assert "nope.csv" in err and "Traceback" not in err
    assert main(["export", str(tmp_path / "nope.pt"), "--name", "x"]) == 2


def test_exported_policies_run_in_the_controllers_estimators(tmp_path: Path, monkeypatch, capsys) -> None:
    """Voxel policies load through the registry (onnx_estimator); Su policies through the
    feature estimator; both reproduce the torch model on tared frames."""
    from grasp_ctrl.estimators.feature_onnx_estimator import load_feature_onnx_policy
    from grasp_ctrl.estimators.registry import load_policy, read_metadata
    from grasp_ctrl.learning.dataset import Dataset
    from grasp_ctrl.learning.train import TensorData, load_checkpoint, model_from_checkpoint, predict_data

    monkeypatch.setenv("GRASP_CTRL_POLICIES", str(tmp_path))
    common = ["--synthetic", "200", "--seed", "6", "--test-per-source", "100", "--quiet", "--epochs", "1"]
    rng = np.random.default_rng(0)
    tared = np.zeros((50, 44))
    tared[:, :19] = -np.abs(rng.normal(0, 300, (50, 19)))
    tared[:, 19] = rng.uniform(20, 400, 50)
    n = len(tared)
    ds = Dataset(
        np.zeros(n, str),
        np.zeros(n, str),
        np.zeros(n),
        tared,
        np.ones((n, 3)),
        np.zeros(n, bool),
        np.repeat(np.eye(3)[None], n, axis=0),
    )
    for arch in ("voxel", "su"):
        ckpt = tmp_path / f"{arch}.pt"
        assert main(["train", *common, "--arch", arch, "--out", str(ckpt)]) == 0
        assert main(["export", str(ckpt), "--name", f"p_{arch}"]) == 0
        json_path = tmp_path / f"p_{arch}.json"
        est = (
            load_policy(f"p_{arch}")
            if arch == "voxel"
            else load_feature_onnx_policy(read_metadata(json_path), json_path, None, 1)
        )
        ref = predict_data(model_from_checkpoint(load_checkpoint(str(ckpt))), TensorData(ds))[0]
        np.testing.assert_allclose(est.estimate(tared, ["f"] * n).f_sensor, ref, atol=1e-4)


OFFICIAL_NPZ = Path(__file__).resolve().parents[3] / "shared" / "data" / "official_icra19" / "icra19_weights.npz"


def test_authors_weights_map_onto_the_voxel_model() -> None:
    if not OFFICIAL_NPZ.is_file():
        pytest.skip("shared data not present")
    from grasp_ctrl.learning.features import model_inputs
    from grasp_ctrl.learning.official import official_model
    from grasp_ctrl.tactile.features import contact_points
    from grasp_ctrl.tactile.voxel import VoxelGrid

    model = official_model(OFFICIAL_NPZ)
    rng = np.random.default_rng(0)
    tared = np.zeros((30, 44))
    tared[:, :19] = -np.abs(rng.normal(0, 300, (30, 19)))
    x = model_inputs(tared)
    with torch.no_grad():
        ours = model(torch.tensor(x["electrode_voxels"]), torch.tensor(x["contact_voxels"])).numpy()
    # independent numpy forward pass of the TF graph (channels-last, kernel 2 stride 2)
    d = np.load(OFFICIAL_NPZ)

    def ln(v, g, b):
        ax = tuple(range(1, v.ndim))
        return (v - v.mean(ax, keepdims=True)) / np.sqrt(v.var(ax, keepdims=True) + 1e-12) * g + b

    def conv(v, w, b):
        n, *sp, c = v.shape
        half = [s // 2 for s in sp]
        if len(sp) == 3:
            p = v.reshape(n, half[0], 2, half[1], 2, half[2], 2, c).transpose(0, 1, 3, 5, 2, 4, 6, 7)
        else:
            p = v.reshape(n, half[0], 2, half[1], 2, c).transpose(0, 1, 3, 2, 4, 5)
        return p.reshape(n, *half, -1) @ w.reshape(-1, w.shape[-1]) + b

    grid = VoxelGrid("icra19")
    e = grid.electrode_grids(tared[:, :19]).astype(float)[..., None]
    c = grid.contact_grids(contact_points(tared)).astype(float)[..., None]
    r = lambda v: np.maximum(v, 0)  # noqa: E731
    a = r(ln(conv(e, d["Conv/weights"], d["Conv/biases"]), d["LayerNorm/gamma"], d["LayerNorm/beta"]))
    b = r(ln(conv(c, d["Conv_1/weights"], d["Conv_1/biases"]), d["LayerNorm_1/gamma"], d["LayerNorm_1/beta"]))
    h = r(
        ln(
            conv(np.concatenate([a, b], -1), d["Conv_2/weights"], d["Conv_2/biases"]),
            d["LayerNorm_2/gamma"],
            d["LayerNorm_2/beta"],
        )
    )
    h = r(ln(conv(h, d["Conv_3/weights"], d["Conv_3/biases"]), d["LayerNorm_3/gamma"], d["LayerNorm_3/beta"]))
    h = r(
        ln(conv(h[:, :, :, 0], d["Conv_4/weights"], d["Conv_4/biases"]), d["LayerNorm_4/gamma"], d["LayerNorm_4/beta"])
    )
    h = h.reshape(len(h), -1)
    h = r(
        ln(
            h @ d["fully_connected/weights"] + d["fully_connected/biases"],
            d["LayerNorm_5/gamma"],
            d["LayerNorm_5/beta"],
        )
    )
    h = r(
        ln(
            h @ d["fully_connected_1/weights"] + d["fully_connected_1/biases"],
            d["LayerNorm_6/gamma"],
            d["LayerNorm_6/beta"],
        )
    )
    net = h @ d["fully_connected_2/weights"] + d["fully_connected_2/biases"]
    np.testing.assert_allclose(ours, -net, atol=2e-3 * max(1.0, np.abs(net).max()))  # ours returns f_sensor


def test_core_commands_do_not_import_torch() -> None:
    from conftest import modules_after

    code = (
        "from grasp_ctrl.cli import build_parser; build_parser(); "
        "import grasp_ctrl.estimators.feature_onnx_estimator, grasp_ctrl.learning.synthetic, grasp_ctrl.bench.fig_pushing"
    )
    assert modules_after(code, {"torch"}) == set()


def test_experiment_models_fig4_is_the_voxel_ablation():
    from grasp_ctrl.learning.pipeline import experiment_models

    assert experiment_models("fig3") == {
        "analytic": ("analytic", None),
        "su": ("su", None),
        "voxel+alpha": ("voxel", 1.0),
    }
    assert experiment_models("fig4") == {
        "voxel+alpha": ("voxel", 1.0),
        "voxel": ("voxel", None),
        "novoxel+alpha": ("novoxel", 1.0),
        "novoxel": ("novoxel", None),
    }
    assert set(experiment_models("fig3+fig4")) == {"analytic", "su", "voxel+alpha", "voxel", "novoxel+alpha", "novoxel"}
    with pytest.raises(ValueError, match="fig3, fig4"):
        experiment_models("fig5")
