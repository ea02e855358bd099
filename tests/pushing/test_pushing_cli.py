"""``pushing-gt`` command: docs/design.md 5.4 contract, errors as one line."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.pushing.io import FORCE_COLUMNS, write_push_csv
from grasp_ctrl.pushing.simulate import simulate_push

BOX_TOML = 'mass_kg = 0.65\nsize_m = [0.12, 0.16]\nmu = 0.1\n'


@pytest.fixture()
def push_files(tmp_path: Path) -> tuple[Path, Path, object]:
    push = simulate_push(np.random.default_rng(11))
    traj = tmp_path / "push.csv"
    write_push_csv(traj, push)
    obj = tmp_path / "box.toml"
    obj.write_text(BOX_TOML)
    return traj, obj, push


@pytest.mark.parametrize("method", ["closed-form", "slsqp"])
def test_writes_forces_csv(push_files, tmp_path: Path, method: str, capsys) -> None:
    traj, obj, push = push_files
    out = tmp_path / "forces.csv"
    assert (
        main(["pushing-gt", "--trajectory", str(traj), "--object", str(obj), "--out", str(out), "--method", method])
        == 0
    )
    rows = list(csv.DictReader(out.open()))
    assert tuple(rows[0].keys()) == FORCE_COLUMNS
    assert len(rows) == len(push.t)
    fx = np.array([float(r["fx_world"]) for r in rows])
    fy = np.array([float(r["fy_world"]) for r in rows])
    moving = np.array([int(r["moving"]) for r in rows])
    ok = ~np.isnan(fx)
    assert ok.sum() > 0.5 * push.in_contact.sum()
    assert np.all(moving[ok] == 1)
    err = np.hypot(fx[ok] - push.f_world_true[ok, 0], fy[ok] - push.f_world_true[ok, 1])
    assert np.median(err) < 0.05
    # object-frame force has the same magnitude
    fxo = np.array([float(r["fx_object"]) for r in rows])
    fyo = np.array([float(r["fy_object"]) for r in rows])
    np.testing.assert_allclose(np.hypot(fxo[ok], fyo[ok]), np.hypot(fx[ok], fy[ok]), rtol=1e-6)
    assert math.isnan(fxo[0])  # the push starts at rest


def test_bad_row_is_reported_by_line(push_files, tmp_path: Path, capsys) -> None:
    traj, obj, _ = push_files
    lines = traj.read_text().splitlines()
    lines[4] = lines[4].replace(lines[4].split(",")[1], "abc", 1)
    traj.write_text("\n".join(lines) + "\n")
    rc = main(["pushing-gt", "--trajectory", str(traj), "--object", str(obj), "--out", str(tmp_path / "f.csv")])
    err = capsys.readouterr().err
    assert rc != 0 and "line 5" in err and "Traceback" not in err


def test_missing_column_and_bad_object(push_files, tmp_path: Path, capsys) -> None:
    traj, obj, _ = push_files
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y\n0,0,0\n")
    assert main(["pushing-gt", "--trajectory", str(bad), "--object", str(obj), "--out", str(tmp_path / "f.csv")]) != 0
    assert "missing column" in capsys.readouterr().err
    obj.write_text("mass_kg = -1\nsize_m = [0.1, 0.1]\nmu = 0.1\n")
    assert main(["pushing-gt", "--trajectory", str(traj), "--object", str(obj), "--out", str(tmp_path / "f.csv")]) == 2
    assert "mass_kg" in capsys.readouterr().err


def test_non_uniform_time_is_rejected(push_files, tmp_path: Path, capsys) -> None:
    traj, obj, _ = push_files
    lines = traj.read_text().splitlines()
    del lines[10]
    traj.write_text("\n".join(lines) + "\n")
    assert main(["pushing-gt", "--trajectory", str(traj), "--object", str(obj), "--out", str(tmp_path / "f.csv")]) != 0
    assert "uniformly sampled" in capsys.readouterr().err
