"""Numbers nobody bounded, readers that trusted their input, and two fault classes.

Each example gives one line naming the file (or flag), the key or line and the allowed
range, never a traceback: huge integers in float keys, bus rates and profile registers,
vanishing masses, 1e308 vectors, NaN flags, corrupt or deeply nested JSON, short or
junk rows in recordings. A finite but huge estimate is ``overforce``; a calibration
that collapses an axis or makes the error worse is refused.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.files.paths import default_hand_file, default_objects_file

HAND_TOML = Path(default_hand_file()).read_text()
OBJECTS_TOML = Path(default_objects_file()).read_text()
HUGE_INT = "9" * 400


def _call(argv: list[str], capsys) -> tuple[int, str]:
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse
        rc = exc.code if isinstance(exc.code, int) else 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return rc, err


def _one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(lines) == 1, err
    return lines[0]


# ---------------------------------------------------------------- 3. numbers from files
def _replace_once(text: str, pattern: str, new: str) -> str:
    out, n = re.subn(pattern, new, text, count=1, flags=re.MULTILINE)
    assert n == 1, pattern
    return out


@pytest.mark.parametrize(
    "pattern, value, key",
    [
        (r"^mass_kg = .*$", f"mass_kg = {HUGE_INT}", "mass_kg"),
        (r"^mass_kg = .*$", "mass_kg = 1e-300", "mass_kg"),
        (r"^mu = .*$", f"mu = -{HUGE_INT}", "mu"),
        (r"^height_m = .*$", f"height_m = {HUGE_INT}", "height_m"),
    ],
)
def test_object_file_numbers_are_range_checked(tmp_path, pattern, value, key):
    path = tmp_path / "objects.toml"
    path.write_text(_replace_once(OBJECTS_TOML, pattern, value))
    with pytest.raises(ConfigError) as exc:
        load_objects(path)
    msg = str(exc.value)
    assert str(path) in msg and key in msg and "\n" not in msg and len(msg) < 400


def test_object_mass_of_1e_300_is_refused_by_run_before_anything_is_written(tmp_path, capsys):
    path = tmp_path / "objects.toml"
    path.write_text(_replace_once(OBJECTS_TOML, r"^mass_kg = .*$", "mass_kg = 1e-300"))
    rc, err = _call(
        [
            "run",
            "--backend",
            "mock",
            "--object-file",
            str(path),
            "--trials",
            "1",
            "--out",
            str(tmp_path / "r"),
            "--quiet",
        ],
        capsys,
    )
    line = _one_error_line(err)
    assert rc == 2 and "mass_kg" in line and ">= 0.001" in line and not (tmp_path / "r").exists()


@pytest.mark.parametrize(
    "table, line, key",
    [
        ("[dynamixel]", "profile_velocity = 100000000", "dynamixel.profile_velocity"),
        ("[dynamixel]", "profile_acceleration = 99999999999", "dynamixel.profile_acceleration"),
        ("[dynamixel]", "baud = 1000000000", "dynamixel.baud"),
        ("[tactile]", f"baud = {HUGE_INT}", "tactile.baud"),
        ("[safety]", f"max_fingertip_force_n = {HUGE_INT}", "safety.max_fingertip_force_n"),
    ],
)
def test_hand_file_bus_settings_and_huge_integers_are_range_checked(tmp_path, table, line, key):
    name = line.split(" =")[0]
    text = re.sub(rf"^{name} = .*\n", "", HAND_TOML.split(table, 1)[1], count=1, flags=re.MULTILINE)
    text = HAND_TOML.split(table, 1)[0] + table + "\n" + line + "\n" + text
    path = tmp_path / "hand.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_hand(path)
    msg = str(exc.value)
    assert key in msg and "\n" not in msg and len(msg) < 400, msg


def test_a_1e308_vector_is_refused_not_normalised_to_zero(tmp_path):
    text = _replace_once(HAND_TOML, r"^task_vector_hand = .*$", "task_vector_hand = [1e308, 1e308, 1e308]")
    path = tmp_path / "hand.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"task_vector_hand: a list of 3 numbers from -1000 to 1000"):
        load_hand(path)


@pytest.mark.parametrize(
    "argv",
    [
        ["plot", "x.json", "--fps", "nan"],
        ["plot", "x.json", "--fps", "inf"],
        ["plot", "x.json", "--fps", "-1"],
        ["plot", "x.json", "--frames", "9" * 400],
        ["pushing-gt", "--trajectory", "t.csv", "--object", "o.toml", "--out", "f.csv", "--k", "1e999"],
        ["sensors", "--seconds", "nan"],
        ["evaluate-direction", "--data", "d.csv", "--threshold", "-inf"],
    ],
)
def test_number_flags_are_checked_for_type_and_range(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    rc, err = _call(argv, capsys)
    assert rc == 2 and argv[-2] in _one_error_line(err)
    assert list(tmp_path.iterdir()) == []


def test_number_helpers_name_the_flag_and_range():
    from grasp_ctrl.numeric.numbers import parse_float, parse_int

    with pytest.raises(UsageError, match=r"^--param tau: a finite number >= 0.1 and <= 20 \(got 'inf'\)$"):
        parse_float("inf", "--param tau", 0.1, 20.0)
    assert parse_float("2.5", "--param tau", 0.1, 20.0) == 2.5
    with pytest.raises(UsageError, match="an integer"):
        parse_int("1" * 400, "--trials", 1, 100)


# ---------------------------------------------------------------- JSON read with limits
@pytest.mark.parametrize(
    "content",
    [
        "[" * 5000 + "]" * 5000,
        '{"a": ' * 40 + "1" + "}" * 40,
        "\x00\xff\xfe binary",
        '{"format": 1, "seed": ' + "9" * 5000 + "}",
    ],
)
def test_a_corrupt_or_absurdly_nested_run_json_is_one_line(tmp_path, capsys, content):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "run.json").write_bytes(
        content.encode("utf-8", "surrogateescape") if isinstance(content, str) else content
    )
    for argv in (["run", "--resume", str(run_dir)], ["score", str(run_dir)]):
        rc, err = _call(argv, capsys)
        assert rc == 2 and "run.json" in _one_error_line(err)


def test_a_json_file_over_the_size_limit_is_not_read(tmp_path):
    from grasp_ctrl.files.json_limits import JsonFileError, read_json

    path = tmp_path / "big.json"
    path.write_text('{"a": "' + "x" * 2000 + '"}')
    with pytest.raises(JsonFileError, match="larger than"):
        read_json(path, max_bytes=1000)
    assert read_json(path)["a"] == "x" * 2000


def test_a_nested_summary_json_does_not_stop_score(tmp_path, capsys, monkeypatch):
    from tests.trials.test_run_fingerprint_and_outputs import _stub_trials

    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--quiet", "--out", str(run_dir)]) == 0
    )
    (run_dir / "summary.json").write_text("[" * 100000)
    rc, _ = _call(["score", str(run_dir)], capsys)
    assert rc == 0


# ---------------------------------------------------------------- 4. readers of recordings
HEADER = (
    "trial_id,sample_idx,timestamp,t_rel_s,pdc,"
    + ",".join(f"e{i}" for i in range(1, 20))
    + ",nx,ny,nz,label_norm,in_paper_trial"
)


def _plate_row(tid: str = "A", pdc: str = "2449", normal: str = "0,0,1") -> str:
    return f"{tid},0,0,0,{pdc}," + ",".join(["3000"] * 19) + f",{normal},1.0,0"


def _plate_file(tmp_path: Path, bad: str) -> Path:
    path = tmp_path / "plate.csv"
    path.write_text(f"{HEADER}\n{_plate_row()}\n{bad}\n{_plate_row()}\n")
    return path


BAD_PLATE_ROWS = [
    ("A,0,0,0,2449,3000", "field(s), the header has"),  # a short row
    (_plate_row(normal="nan,0,1"), "nx: a finite number"),  # a NaN normal
    (_plate_row(normal="0,0,0"), "unit plate normal"),  # a zero normal
    (_plate_row(pdc="1e300"), "pdc: a number from 0 to 4095"),
    ("\x00\x01\x02\xff junk", "field(s)"),  # binary junk
]


@pytest.mark.parametrize("bad, why", BAD_PLATE_ROWS)
def test_plate_recording_bad_rows_are_named_by_line_or_skipped(tmp_path, bad, why):
    from grasp_ctrl.evaluation.robotic_finger import read_trials

    path = _plate_file(tmp_path, bad)
    with pytest.raises(UsageError) as exc:
        read_trials(path)
    assert f"{path}: line 3:" in str(exc.value) and why in str(exc.value) and "--skip-bad-rows" in str(exc.value)
    (trial,) = read_trials(path, skip_bad_rows=True)
    assert len(trial) == 2 and np.all(np.isfinite(trial.normals))


@pytest.mark.parametrize("command", ["evaluate-direction", "calibrate"])
def test_plate_recording_commands_give_one_line_for_a_bad_row(tmp_path, capsys, command):
    path = _plate_file(tmp_path, BAD_PLATE_ROWS[1][0])
    argv = [command, "--data", str(path)] + (
        ["--policy", "linear_mock", "--out", str(tmp_path / "c.json")] if command == "calibrate" else []
    )
    rc, err = _call(argv, capsys)
    line = _one_error_line(err)
    assert rc == 2 and "line 3" in line and "nx" in line
    assert not (tmp_path / "c.json").exists()


def test_sensors_emulate_from_a_bad_recording_is_one_line(tmp_path):
    from grasp_ctrl.emulators.tactile_bridge import RecordingSource

    path = _plate_file(tmp_path, "A,0,0,0,nan," + ",".join(["3000"] * 19) + ",0,0,1,1.0,0")
    with pytest.raises(ValueError, match="line 3: pdc: a finite number"):
        RecordingSource(path)
    assert len(RecordingSource(path, skip_bad_rows=True)) == 2


PUSH_HEADER = "t,x,y,theta,contact_x,contact_y,in_contact"


@pytest.mark.parametrize(
    "body, why",
    [
        (b"\x89PNG\r\n\x1a\n\x00\x00binary", "missing column"),
        ((PUSH_HEADER + "\n0,0,0,0,0,0,1\n0.1,1e300,0,0,0,0,1\n0.2,0,0,0,0,0,1\n").encode(), "line 3: x"),
        ((PUSH_HEADER + "\n0,0,0,0,0,0,1\n0.1,0,0\n0.2,0,0,0,0,0,1\n").encode(), "line 3:"),
        ((PUSH_HEADER + "\n0,0,0,0,0,0,1\n0,0,0,0,0,0,1\n").encode(), "increasing times"),
        ((PUSH_HEADER + "\n" + "9" * 200000 + "\n").encode(), "line 2"),
    ],
)
def test_pushing_gt_on_binary_or_pathological_csv_is_one_line(tmp_path, capsys, body, why):
    traj = tmp_path / "push.csv"
    traj.write_bytes(body)
    obj = tmp_path / "box.toml"
    obj.write_text("mass_kg = 0.65\nsize_m = [0.12, 0.16]\nmu = 0.1\n")
    rc, err = _call(
        ["pushing-gt", "--trajectory", str(traj), "--object", str(obj), "--out", str(tmp_path / "f.csv")], capsys
    )
    line = _one_error_line(err)
    assert rc == 2 and why in line and str(traj) in line
    assert not (tmp_path / "f.csv").exists()


# ---------------------------------------------------------------- 5. fault classes
@pytest.mark.parametrize("value", [1e3, 1e200, 1e308, -1e308])
def test_a_finite_but_huge_estimate_is_overforce(hand, objects, value):
    from grasp_ctrl.controller.machine import GraspController
    from grasp_ctrl.controller.snapshot import Snapshot

    ctrl = GraspController(hand, objects["lego"], np.array([0.0, 0.0, 0.2]))
    n = len(hand.fingers)
    q = np.array([j.open_rad for j in hand.joints])
    f = np.zeros((n, 3))
    f[1] = value
    snap = Snapshot(
        t=0.0,
        q=q,
        p_palm_world=np.zeros(3),
        tare_ready=True,
        in_contact=np.ones(n, bool),
        f_sensor=f,
        f_hand=f,
        f_world=f,
        grip_n=np.zeros(n),
    )
    cmd = ctrl.tick(snap)
    assert ctrl.state == "fault" and ctrl.failure_reason == "overforce", ctrl.failure_detail
    assert "inf" not in ctrl.failure_detail and np.all(np.isfinite(cmd.q_goal))


def test_a_fit_that_collapses_an_axis_or_makes_the_error_worse_is_named():
    from grasp_ctrl.evaluation.calibration_checks import fit_problems

    good = {"fit": {"before": {"median_deg": 20.0}, "after": {"median_deg": 5.0}}}
    assert fit_problems(np.eye(3), good) == []
    assert "collapses an axis" in fit_problems(np.diag([1.0, 1.0, 0.0]), good)[0]
    worse = {
        "fit": {"before": {"median_deg": 5.0}, "after": {"median_deg": 9.0}},
        "test": {"before": {"median_deg": 5.0}, "after": {"median_deg": 5.1}},
    }
    (problem,) = fit_problems(np.eye(3), worse)
    assert "fit error worse" in problem
    assert fit_problems(np.full((3, 3), math.nan), good)


def test_calibrate_refuses_a_degenerate_correction_unless_allowed(tmp_path, capsys):
    from grasp_ctrl.estimators.linear import fit_linear
    from grasp_ctrl.learning.dataset import write_raw_csv
    from grasp_ctrl.learning.synthetic import generate, generate_trials

    nominal = generate(600, seed=11, sources=("rigid-ft",))
    w, b = fit_linear(nominal.tared, nominal.f_sensor)
    (tmp_path / "base.json").write_text(
        json.dumps(
            {
                "name": "base",
                "kind": "linear",
                "sensor_type": "biotac",
                "has_variance": False,
                "weights_n_per_count": w.tolist(),
                "bias_n": b.tolist(),
            }
        )
    )
    rows = [t.raw_rows() for t in generate_trials(600, seed=12, sources=("rigid-ft",))]
    for r in rows:
        r.f_sensor = r.f_sensor * np.array([0.0, 1.0, 1.0])  # labels without an x axis: stretch 0
    write_raw_csv(tmp_path / "flat.csv", rows)
    argv = [
        "calibrate",
        "--data",
        str(tmp_path / "flat.csv"),
        "--policy",
        str(tmp_path / "base.json"),
        "--out",
        str(tmp_path / "cal.json"),
        "--model",
        "gains",
    ]
    rc, err = _call(argv, capsys)
    assert rc == 2 and "collapses an axis" in _one_error_line(err)
    assert not (tmp_path / "cal.json").exists()
    rc, err = _call(argv + ["--allow-worse"], capsys)
    assert rc == 0 and "WARNING" in err and (tmp_path / "cal.json").exists()


@pytest.mark.parametrize("spec", ["1:inf:1", "1:20:1e-320", "nan", "1,2,1e999", "3:1:1", "1:2", "0:1:0.1"])
def test_sweep_values_are_checked_before_the_list_is_built(spec):
    from grasp_ctrl.numeric.numbers import parse_values

    with pytest.raises(UsageError, match=r"^--param tau_n"):
        parse_values(spec, "--param tau_n", 0.1, 20.0)
    assert parse_values("1:2.5:0.5", "--param tau_n", 0.1, 20.0) == [1.0, 1.5, 2.0, 2.5]


@pytest.mark.parametrize(
    "key, value",
    [
        ("settings", {"ramp_tolerance_n": int(HUGE_INT)}),
        ("settings", {"ramp_tolerance_n": 1e300}),
        ("objects", int(HUGE_INT)),
    ],
)
def test_a_400_digit_number_in_run_json_is_one_line_on_resume(tmp_path, capsys, monkeypatch, key, value):
    from tests.trials.test_run_fingerprint_and_outputs import _stub_trials

    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert (
        main(["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--quiet", "--out", str(run_dir)]) == 0
    )
    doc = json.loads((run_dir / "run.json").read_text())
    if key == "settings":
        doc["settings"].update(value)
    else:
        doc["objects"][0]["mass_kg"] = value
    (run_dir / "run.json").write_text(json.dumps(doc))
    capsys.readouterr()
    rc, err = _call(["run", "--resume", str(run_dir), "--quiet"], capsys)
    line = _one_error_line(err)
    assert rc == 2 and ("ramp_tolerance_n" in line or "mass_kg" in line) and len(line) < 400
