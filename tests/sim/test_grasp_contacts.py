"""Grasp contacts recorded in MuJoCo: the recorder, the CSV file, and the presses made from them
(the default policy's refit and the synthetic ball-ft source)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.paths import default_hand_file, default_objects_file
from grasp_ctrl.kinematics.fingertip import PAD_X_MIN_M, SKIN_RADIUS_M
from grasp_ctrl.sim.biotac.grasp_contacts import NUMERIC_COLUMNS, TEXT_COLUMNS, GraspContacts, csv_text, read_csv
from grasp_ctrl.sim.biotac.presses import contact_presses, reverse_shear

pytest.importorskip("mujoco")

HEADER = ",".join(TEXT_COLUMNS + NUMERIC_COLUMNS)
GOOD_ROW = "lego,index,1.5,-0.007,0.0,-0.0055,0.0,0.0,-1.0,0.1,0.0,1.2"


@pytest.fixture(scope="module")
def recorded() -> GraspContacts:
    from grasp_ctrl.trials.episode.contact_recorder import record_grasp_contacts

    hand = load_hand(default_hand_file())
    lego = load_objects(default_objects_file())["lego"]
    return record_grasp_contacts(hand, [lego], trials=1, seed=1000, every=5)


def test_recorded_contacts_lie_on_the_modelled_skin(recorded: GraspContacts) -> None:
    assert len(recorded) > 100
    assert set(recorded.object) == {"lego"}
    assert set(recorded.finger) <= {"index", "middle", "thumb"}
    p, n, f = recorded.p_sensor, recorded.n_sensor, recorded.f_sensor
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-9)
    # the pad is a cylinder of the skin radius about x (x <= 0), the cap a sphere (x > 0)
    radius = np.where(p[:, 0] > 0, np.linalg.norm(p, axis=1), np.hypot(p[:, 1], p[:, 2]))
    np.testing.assert_allclose(radius, SKIN_RADIUS_M, atol=1e-9)
    assert np.all(p[:, 0] >= PAD_X_MIN_M - 1e-12)
    # the object presses into the skin: the force has a part against the outward normal
    assert np.all(np.linalg.norm(f, axis=1) >= 0.05)
    assert np.median(-np.sum(f * n, axis=1)) > 0.5
    assert np.all(np.diff(recorded.t_s[recorded.finger == "thumb"]) > 0)


def test_csv_reads_back_the_same_numbers(recorded: GraspContacts, tmp_path: Path) -> None:
    path = tmp_path / "contacts.csv"
    path.write_text(csv_text(recorded))
    back = read_csv(path)
    for name in ("object", "finger", "t_s", "p_sensor", "n_sensor", "f_sensor"):
        np.testing.assert_array_equal(getattr(back, name), getattr(recorded, name), err_msg=name)


@pytest.mark.parametrize(
    ("row", "says"),
    [
        ("lego,index,1.5,-0.007,0.0,-0.0055,0.0,0.0,-0.5,0.1,0.0,1.2", "unit normal"),
        ("lego,index,1.5,-0.7,0.0,-0.0055,0.0,0.0,-1.0,0.1,0.0,1.2", "p_x_m"),
        ("lego,index,1.5,-0.007,0.0,-0.0055,0.0,0.0,-1.0,0.1,0.0,nan", "f_z_n"),
        ("lego,index,1.5,-0.007", "field(s)"),
    ],
)
def test_a_bad_row_is_named_by_its_line(tmp_path: Path, row: str, says: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(f"{HEADER}\n{GOOD_ROW}\n{row}\n")
    with pytest.raises(UsageError, match=f"line 3: .*{re.escape(says)}"):
        read_csv(path)
    back = read_csv(path, skip_bad_rows=True)
    assert len(back) == 1


def test_not_a_contacts_file(tmp_path: Path) -> None:
    path = tmp_path / "other.csv"
    path.write_text("a,b\n1,2\n")
    with pytest.raises(UsageError, match="missing column"):
        read_csv(path)
    with pytest.raises(UsageError, match="cannot read"):
        read_csv(tmp_path / "absent.csv")
    empty = tmp_path / "empty.csv"
    empty.write_text(HEADER + "\n")
    with pytest.raises(UsageError, match="no contacts"):
        read_csv(empty)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fields=st.lists(st.text(max_size=12), min_size=0, max_size=14))
def test_any_row_is_read_or_refused_in_one_line(tmp_path: Path, fields: list[str]) -> None:
    path = tmp_path / "fuzz.csv"
    path.write_text(f"{HEADER}\n" + ",".join(f.replace("\n", " ").replace("\r", " ") for f in fields) + "\n")
    try:
        back = read_csv(path)
    except UsageError as exc:
        assert "\n" not in str(exc)
    else:
        assert np.all(np.isfinite(back.p_sensor)) and np.all(np.abs(back.f_sensor) <= 100.0)


def _contacts(p: np.ndarray, n: np.ndarray, f: np.ndarray) -> GraspContacts:
    """Recorded contacts made up from arrays (one object, the index)."""
    k = len(p)
    return GraspContacts(np.full(k, "box", dtype=object), np.full(k, "index", dtype=object), np.zeros(k), p, n, f)


def test_contact_presses_keep_each_contacts_direction() -> None:
    p = np.array([[-0.007, 0.0, -SKIN_RADIUS_M], [0.002, 0.0, -np.sqrt(SKIN_RADIUS_M**2 - 0.002**2)]])
    n = p / np.array([[SKIN_RADIUS_M], [SKIN_RADIUS_M]])
    n[0] = (0.0, 0.0, -1.0)
    f = np.array([[0.5, 0.0, 2.0], [-1.5, 0.3, 1.5]])
    tared, labels = contact_presses(_contacts(p, n, f), 200, seed=4)
    assert tared.shape == (200, 44) and labels.shape == (200, 3)
    unit = labels / np.linalg.norm(labels, axis=1, keepdims=True)
    both = np.vstack([f, reverse_shear(f, n, np.ones(2, dtype=bool))])
    cos = unit @ (both / np.linalg.norm(both, axis=1, keepdims=True)).T
    assert np.all(np.max(cos, axis=1) > 1 - 1e-12)
    reversed_share = float(np.mean(np.max(cos[:, 2:], axis=1) > 1 - 1e-12))
    assert 0.3 < reversed_share < 0.7
    ratio = np.linalg.norm(labels, axis=1) / np.min(np.linalg.norm(f, axis=1))
    assert ratio.min() >= 0.25 - 1e-12
    # pressed electrodes read negative, the pdc positive (config/sensor_layout.py)
    assert np.all(tared[:, 19] > 0)


def test_reverse_shear_keeps_the_normal_part() -> None:
    n = np.array([[0.0, 0.0, -1.0], [0.0, 0.6, -0.8]])
    f = np.array([[0.4, -0.2, 2.0], [1.0, 0.5, 1.5]])
    back = reverse_shear(f, n, np.array([True, False]))
    np.testing.assert_allclose(np.sum(back * n, axis=1), np.sum(f * n, axis=1))
    np.testing.assert_allclose(back[0], [-0.4, 0.2, 2.0])
    np.testing.assert_array_equal(back[1], f[1])


def test_ball_ft_presses_at_the_contacts_and_the_other_sources_are_unchanged() -> None:
    from grasp_ctrl.learning.synthetic import generate, mock_biotac_forward

    # one distinctive contact: on the tip cap's side, pushed along the finger and sideways
    p0 = SKIN_RADIUS_M * np.array([0.6, 0.8, 0.0])
    f0 = np.array([-1.0, -2.0, 0.5])
    one = _contacts(p0[None], (p0 / SKIN_RADIUS_M)[None], f0[None])
    first_points: list[np.ndarray] = []
    base = mock_biotac_forward()

    def forward(p: np.ndarray, f: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        first_points.append(p[-1].copy())
        return base(p, f, rng)

    plain = generate(300, seed=2)
    with_contact = generate(300, seed=2, forward=forward, contacts=one)
    np.testing.assert_array_equal(
        with_contact.tared[with_contact.source == "rigid-ft"], plain.tared[plain.source == "rigid-ft"]
    )
    ball = with_contact.source == "ball-ft"
    unit = with_contact.f_sensor[ball] / np.linalg.norm(with_contact.f_sensor[ball], axis=1, keepdims=True)
    f_back = reverse_shear(f0[None], (p0 / SKIN_RADIUS_M)[None], np.ones(1, dtype=bool))[0]
    along = np.maximum(unit @ (f0 / np.linalg.norm(f0)), unit @ (f_back / np.linalg.norm(f_back)))
    share = float(np.mean(along > np.cos(np.radians(15))))
    assert 0.2 < share < 0.8  # about half of the ball-ft presses follow the recorded contact
    near = [np.linalg.norm(p - p0) < 0.004 for p in first_points]
    assert any(near) and not all(near)


def test_cli_records_and_fit_mock_policies_uses_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("torch")
    out = tmp_path / "contacts.csv"
    args = ["grasp-contacts", "--objects", "lego", "--trials", "1", "--every", "10", "--out", str(out)]
    assert main(args) == 0
    assert "wrote" in capsys.readouterr().out
    assert main(args) == 2  # exists: refused without --force
    assert "--force" in capsys.readouterr().err
    assert main(["grasp-contacts", "--objects", "lego", "--out", str(tmp_path / "x.txt")]) == 2
    fit_dir = tmp_path / "fit"
    fit_dir.mkdir()
    fit = ["fit-mock-policies", "--samples", "300", "--grasp-contacts", str(out), "--out-dir", str(fit_dir)]
    assert main(fit) == 0
    meta = json.loads((fit_dir / "mlp_mock.json").read_text())
    assert "oracle grasps in MuJoCo" in meta["training_data"]
    assert meta["metrics_grasp_contacts"]["test_samples"] == 60
    assert "grasp-contacts" in meta["provenance"]


def test_train_refuses_grasp_contacts_without_synthetic(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("torch")
    data = tmp_path / "d.csv"
    data.write_text("x\n")
    assert main(["train", "--data", str(data), "--grasp-contacts", str(data), "--arch", "su"]) == 2
    assert "--grasp-contacts goes with --synthetic" in capsys.readouterr().err
