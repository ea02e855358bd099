"""Rerun recordings of trials: `plot TRIAL --rrd OUT.rrd` and `run --rrd DIR` (skipped without the viz extra)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rerun")

from grasp_ctrl.cli import main


def _rerun_cli() -> str:
    found = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    if not Path(found).is_file():
        pytest.skip("the rerun command line (comes with rerun-sdk) is not on PATH")
    return found


def _verify(path: Path) -> None:
    done = subprocess.run(
        [_rerun_cli(), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr


def _entities(path: Path) -> dict[str, set[str]]:
    """Entity path -> the archetypes logged to it, from `rerun rrd print`."""
    done = subprocess.run(
        [_rerun_cli(), "rrd", "print", str(path)], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    out: dict[str, set[str]] = {}
    for m in re.finditer(r" - (/\S+) - data columns: \[([^\]]*)\]", done.stdout):
        out.setdefault(m.group(1), set()).update(c.split(":")[0] for c in m.group(2).split())
    return out


@pytest.fixture(scope="module")
def mujoco_trial(tmp_path_factory) -> Path:
    pytest.importorskip("mujoco")
    run_dir = tmp_path_factory.mktemp("rrd") / "run"
    assert (
        main(
            [
                "run",
                "--backend",
                "mujoco",
                "--objects",
                "paper_cup",
                "--policy",
                "oracle",
                "--trials",
                "1",
                "--out",
                str(run_dir),
                "--quiet",
            ]
        )
        == 0
    )
    return run_dir / "trials" / "oracle" / "paper_cup" / "trial_000.json"


def test_plot_rrd_holds_hand_object_forces_states_and_series(mujoco_trial, tmp_path, capsys):
    out = tmp_path / "trial.rrd"
    assert main(["plot", str(mujoco_trial), "--rrd", str(out)]) == 0
    assert "recording:" in capsys.readouterr().out and not (mujoco_trial.parent / "trial_000.png").exists()
    _verify(out)
    entities = _entities(out)
    for finger in ("index", "middle", "ring", "thumb"):
        assert "LineStrips3D" in entities[f"/world/hand/{finger}"]
        assert "Arrows3D" in entities[f"/world/forces/{finger}/estimated"]
        assert "Arrows3D" in entities[f"/world/forces/{finger}/true"]
    assert {"Transform3D", "Cylinders3D"} <= entities["/world/object"]
    assert "Points3D" in entities["/world/hand/palm"]
    assert "TextLog" in entities["/controller/state"]
    for series in ("/signals/tau", "/signals/release", "/signals/release_threshold", "/signals/grip/index"):
        assert "Scalars" in entities[series], series


def test_run_rrd_writes_one_recording_per_trial(tmp_path, capsys):
    rrd_dir = tmp_path / "rrd"
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--objects",
                "lego",
                "--policy",
                "oracle",
                "--trials",
                "2",
                "--out",
                str(tmp_path / "run"),
                "--rrd",
                str(rrd_dir),
                "--quiet",
                "--jobs",
                "1",
            ]
        )
        == 0
    )
    files = sorted(rrd_dir.rglob("*.rrd"))
    assert [f.relative_to(rrd_dir).as_posix() for f in files] == [
        "oracle/lego/trial_000.rrd",
        "oracle/lego/trial_001.rrd",
    ]
    _verify(files[0])
    assert "Boxes3D" in _entities(files[0])["/world/object"]  # lego is a box
    record = tmp_path / "run" / "trials" / "oracle" / "lego" / "trial_000.json"
    capsys.readouterr()
    assert main(["plot", str(record), "--rrd", str(tmp_path / "trial.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ".rrd" in err[0]


def test_recording_errors_are_one_line(tmp_path, capsys):
    assert (
        main(
            [
                "run",
                "--backend",
                "mock",
                "--objects",
                "lego",
                "--trials",
                "1",
                "--out",
                str(tmp_path / "r"),
                "--rrd",
                str(tmp_path / "x"),
                "--no-tick-logs",
                "--quiet",
            ]
        )
        == 2
    )
    assert "--no-tick-logs" in capsys.readouterr().err and not (tmp_path / "r").exists()
