"""Config loading: the shipped files load; bad files give one line naming file and key, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.config.objects import default_set
from grasp_ctrl.errors import ConfigError
from grasp_ctrl.files.paths import REPO_ROOT

LEAP = REPO_ROOT / "hand_configs" / "leap_hand.toml"
OBJECTS = REPO_ROOT / "hand_configs" / "objects.toml"


def test_leap_hand_loads(hand):
    assert hand.name == "leap_hand"
    assert len(hand.joints) == 16
    assert sorted(j.servo_id for j in hand.joints) == list(range(16))
    assert [f.name for f in hand.fingers] == ["index", "middle", "ring", "thumb"]
    assert hand.grasp.release_finger == "index"
    for j in hand.joints:
        assert j.lower_rad < j.upper_rad
        assert j.lower_rad <= j.open_rad <= j.upper_rad


def test_paper_objects_present(objects):
    assert set(default_set(OBJECTS)) == {
        "chips_can",
        "cleanser",
        "lego",
        "plastic_bottle",
        "paper_cup",
        "mustard_bottle",
    }
    for name in ("paper_cup", "plastic_bottle"):
        assert objects[name].deformable and objects[name].crush_force_n > 0
    for name in ("chips_can", "cleanser", "lego", "mustard_bottle"):
        assert not objects[name].deformable and objects[name].crush_force_n is None


def _mutate(tmp_path: Path, src: Path, old: str, new: str) -> Path:
    text = src.read_text()
    assert old in text, old
    out = tmp_path / src.name
    out.write_text(text.replace(old, new, 1))
    return out


@pytest.mark.parametrize(
    "old,new,key,expected",
    [
        ('name = "leap_hand"\n', "", "name", "missing"),
        ("rate_hz = 100.0", 'rate_hz = "fast"', "rate_hz", "finite number"),
        ("servo_id = 5\n", "servo_id = 4\n", "servo_id", "unique servo ids"),
        ("upper_rad = 2.23", "upper_rad = -0.6", "fingers[0].joints[0].upper_rad", "> lower_rad"),
        ('on_fault = "open"', 'on_fault = "panic"', "safety.on_fault", "one of hold, open, torque_off"),
        ("stale_after_s = 0.05", "stale_afer_s = 0.05", "tactile.stale_afer_s", "known key"),
        ("axis = [0.0, 0.0, -1.0]", "axis = [0.0, 0.0, 0.0]", "fingers[0].joints[0].axis", "non-zero"),
        ('release_finger = "index"', 'release_finger = "ring"', "grasp.release_finger", "grasp = true"),
    ],
)
def test_bad_hand_file_names_file_and_key(tmp_path, old, new, key, expected):
    bad = _mutate(tmp_path, LEAP, old, new)
    with pytest.raises(ConfigError) as err:
        load_hand(bad)
    assert str(bad) in str(err.value)
    assert key in err.value.key
    assert expected in err.value.expected


@pytest.mark.parametrize(
    "old,new,key,expected",
    [
        ("mass_kg = 0.205", "mass_kg = -1.0", "objects.chips_can.mass_kg", ">"),
        ("crush_force_n = 3.2\n", "", "objects.paper_cup.crush_force_n", "missing"),
        ("tip_force_n = 6.0", "tip_force_n = 6.0\ncrush_force_n = 3.0", "objects.chips_can.crush_force_n", "rigid"),
        ('shape = "box"', 'shape = "sphere"', "objects.cleanser.shape", "cylinder, box"),
        ('"lego",', '"duplo",', "default_set", "unknown"),
        ("offset_m = [0.0, 0.02]", "offset_m = [0.0, 0.04]", "objects.mustard_bottle.cap.offset_m", "cap's base"),
        (
            "contact_height_m = 0.162",
            "contact_height_m = 0.18",
            "objects.mustard_bottle.cap.contact_height_m",
            "below its top",
        ),
        (
            "contact_height_m = 0.162",
            "contact_height_m = 0.15",
            "objects.mustard_bottle.cap.contact_height_m",
            "> 0.16",
        ),
        ('finger = "index"', 'finger = "index"\nshape = "dome"', "objects.mustard_bottle.cap.shape", "a known key"),
    ],
)
def test_bad_object_file_names_file_and_key(tmp_path, old, new, key, expected):
    bad = _mutate(tmp_path, OBJECTS, old, new)
    with pytest.raises(ConfigError) as err:
        load_objects(bad)
        default_set(bad)
    assert key in err.value.key
    assert expected in err.value.expected


def test_unparsable_and_missing_files(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text("name = [unclosed\n")
    with pytest.raises(ConfigError, match="valid TOML"):
        load_hand(broken)
    with pytest.raises(ConfigError, match="file not found"):
        load_hand(tmp_path / "nope.toml")


def test_cli_bad_hand_one_line_exit_2(tmp_path, capsys):
    bad = _mutate(tmp_path, LEAP, "rate_hz = 100.0", "rate_hz = -5.0")
    status = main(["run", "--backend", "mock", "--hand", str(bad), "--trials", "1", "--objects", "lego", "--quiet"])
    assert status == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert str(bad) in err[0] and "rate_hz" in err[0]


def test_cli_subprocess_no_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("this is not toml = = =")
    proc = subprocess.run(
        [sys.executable, str(REPO_ROOT / "launch.py"), "run", "--backend", "mock", "--hand", str(bad)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert str(bad) in proc.stderr


def test_cap_finger_must_be_a_grasping_finger_of_the_hand(hand, objects):
    from dataclasses import replace

    from grasp_ctrl.controller.machine import GraspController

    mustard = objects["mustard_bottle"]
    for finger in ("pinky", "ring"):  # unknown; not grasping in the LEAP hand file
        bad = replace(mustard, cap=replace(mustard.cap, finger=finger))
        with pytest.raises(ConfigError) as err:
            GraspController(hand, bad, np.zeros(3))
        assert err.value.key == "cap.finger" and "grasping finger" in err.value.expected


def test_cap_contact_out_of_the_fingers_reach_is_refused(hand, objects):
    from dataclasses import replace

    from grasp_ctrl.controller.machine import GraspController

    mustard = objects["mustard_bottle"]
    far = replace(mustard, grasp_height_m=0.02)  # the cap 14 cm above the other fingertips
    with pytest.raises(ConfigError) as err:
        GraspController(hand, far, np.zeros(3))
    assert err.value.key == "cap.contact_height_m"


def test_profiles_survive_a_round_trip_through_their_table(objects):
    from grasp_ctrl.config.objects import revalidate

    for obj in objects.values():
        assert revalidate(obj, "round trip") == obj
