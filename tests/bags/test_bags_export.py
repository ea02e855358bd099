"""``export-bag`` and ``run --mcap``: trials and tactile recordings as ROS 2 bags in MCAP, read back
with rosbags (skipped without the ros extra)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")
pytest.importorskip("rosbags")

from rosbags.highlevel import AnyReader
from scipy.spatial.transform import Rotation

from grasp_ctrl.bags import topics
from grasp_ctrl.bags.recording import read_recording
from grasp_ctrl.bags.trial_messages import raw_frame_columns
from grasp_ctrl.cli import main
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.files.paths import default_hand_file
from grasp_ctrl.hardware.base import TactileFrame
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.loop.ticklog import read_tick_log
from grasp_ctrl.tactile_link.recorder import FrameRecorder

FINGERS = ("index", "middle", "ring", "thumb")
REPO = Path(__file__).resolve().parents[2]


def _run(tmp: Path, trials: int = 1, extra: tuple[str, ...] = ()) -> int:
    argv = ["run", "--backend", "mock", "--objects", "lego", "--policy", "oracle", "--trials", str(trials)]
    return main([*argv, "--out", str(tmp), "--quiet", "--jobs", "1", *extra])


@pytest.fixture(scope="module")
def trial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run_dir = tmp_path_factory.mktemp("bags") / "run"
    assert _run(run_dir) == 0
    return run_dir / "trials" / "oracle" / "lego" / "trial_000.json"


def _read(path: Path) -> tuple[dict[str, tuple[str, int]], list[tuple[str, int, object]], tuple[int, int]]:
    """(topic -> (type, count), every message deserialised, (first, last) log time) of a bag."""
    with AnyReader([path]) as reader:
        types = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        msgs = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
        return types, msgs, (reader.start_time, reader.end_time - 1)


def test_a_trial_reads_back_as_a_ros2_bag_matching_its_tick_log(trial: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "trial.mcap"
    assert main(["export-bag", str(trial), "--out", str(out)]) == 0
    printed = capsys.readouterr()
    assert f"bag: {out}" in printed.out and "no /biotac_pub" in printed.err  # a run without --raw-frames
    columns, cols = read_tick_log(trial.with_name("trial_000_ticks.parquet"))
    record = json.loads(trial.read_text())
    types, msgs, (first, last) = _read(out)
    n = len(cols["t"])

    per_tick = {
        topics.JOINT_STATES: "sensor_msgs/msg/JointState",
        topics.JOINT_GOALS: "sensor_msgs/msg/JointState",
        topics.CONTROLLER_STATE: "std_msgs/msg/String",
        topics.OBJECT_POSE: "geometry_msgs/msg/PoseStamped",
        topics.TF: "tf2_msgs/msg/TFMessage",
    }
    for f in FINGERS:
        per_tick[f"/fingertips/{f}/force_estimated"] = "geometry_msgs/msg/WrenchStamped"
        per_tick[f"/fingertips/{f}/force_true"] = "geometry_msgs/msg/WrenchStamped"
    expected = {topic: (kind, n) for topic, kind in per_tick.items()}
    expected[topics.CONTROLLER_TRANSITIONS] = ("std_msgs/msg/String", len(record["transitions"]))
    expected[topics.TRIAL_EVENTS] = ("std_msgs/msg/String", len(record["events"]))
    assert types == expected
    assert len(msgs) == sum(c for _, c in expected.values())  # every message deserialised
    t_ns = np.round(cols["t"] * 1e9).astype(np.int64)
    assert (first, last) == (int(t_ns[0]), int(t_ns[-1]))

    # the wrench at a tick is the tick log's row, in the fingertip's sensor frame, stamped with its time
    k = n // 2
    wrenches = [m for topic, t, m in msgs if topic == "/fingertips/thumb/force_estimated"]
    w = wrenches[k]
    assert w.header.frame_id == "thumb_sensor"
    assert w.header.stamp.sec * 10**9 + w.header.stamp.nanosec == t_ns[k]
    f = w.wrench.force
    assert (f.x, f.y, f.z) == tuple(float(cols[f"thumb_f{a}_sensor"][k]) for a in "xyz")
    true = [m for topic, _, m in msgs if topic == "/fingertips/thumb/force_true"][k].wrench.force
    assert (true.x, true.y, true.z) == tuple(float(cols[f"thumb_true_f{a}_sensor"][k]) for a in "xyz")

    hand = load_hand(default_hand_file())
    joints = [m for topic, _, m in msgs if topic == topics.JOINT_STATES][k]
    assert list(joints.name) == [j.name for j in hand.joints]
    assert np.array_equal(joints.position, [cols[f"q{j}"][k] for j in range(len(hand.joints))])
    assert np.array_equal(joints.effort, [cols[f"current{j}"][k] for j in range(len(hand.joints))])  # A
    states = [m.data for topic, _, m in msgs if topic == topics.CONTROLLER_STATE]
    assert states == [str(s) for s in cols["state"]]
    transitions = [m.data for topic, _, m in msgs if topic == topics.CONTROLLER_TRANSITIONS]
    assert transitions == [f"{a} -> {b}" for _, a, b in record["transitions"]]
    pose = [m for topic, _, m in msgs if topic == topics.OBJECT_POSE][k]
    assert pose.header.frame_id == "world" and pose.pose.position.z == float(cols["object_z_world"][k])

    # /tf: world -> hand -> ... -> each sensor frame is the hand file's forward kinematics at the logged angles
    tf = [m for topic, _, m in msgs if topic == topics.TF][k]
    edges = {tr.child_frame_id: tr for tr in tf.transforms}
    q = np.array([cols[f"q{j}"][k] for j in range(len(hand.joints))])
    kin = HandKinematics(hand)
    for finger in FINGERS:
        frame, R, p = f"{finger}_sensor", np.eye(3), np.zeros(3)
        while frame != "world":
            tr = edges[frame]
            r, x = tr.transform.rotation, tr.transform.translation
            R_e = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
            R, p = R_e @ R, R_e @ p + [x.x, x.y, x.z]
            frame = tr.header.frame_id
        palm = np.array([cols[f"palm_{a}_world"][k] for a in "xyz"])
        T = kin.fk(finger, q)
        assert np.allclose(R, T[:3, :3], atol=1e-9) and np.allclose(p, T[:3, 3] + palm, atol=1e-9)


def test_a_run_trials_frames_and_currents_round_trip_through_its_bag(tmp_path: Path, capsys) -> None:
    """``run --mcap``: the tick logs keep each fingertip's whole raw frame and the joint currents;
    the bag's frames imported back give the recording those frames make, and its efforts are the
    currents (that the log holds what the sensors and servos gave: test_ticklog_raw_frames.py)."""
    run_dir, bags = tmp_path / "run", tmp_path / "bags"
    assert _run(run_dir, extra=("--mcap", str(bags))) == 0
    assert "no /biotac_pub" not in capsys.readouterr().err
    assert json.loads((run_dir / "run.json").read_text())["raw_frames"] is True  # --mcap turns it on
    ticks = run_dir / "trials" / "oracle" / "lego" / "trial_000_ticks.parquet"
    _, cols = read_tick_log(ticks)
    t = cols["t"]
    frames = {f: np.stack([cols[c] for c in raw_frame_columns(f)], axis=1).astype(int) for f in FINGERS}
    hand = load_hand(default_hand_file())
    sensor_id = {f.name: f.sensor_id for f in hand.fingers}
    original = tmp_path / "original.csv"
    with FrameRecorder(original) as rec:
        for k in range(len(t)):
            rec.write(TactileFrame(sensor_id[f], k, float(t[k]), frames[f][k]) for f in FINGERS)

    bag, back = bags / "oracle" / "lego" / "trial_000.mcap", tmp_path / "back.csv"
    types, msgs, _ = _read(bag)
    assert types[topics.BIOTAC] == ("biotac_sensors/msg/BioTacHand", len(t))
    first = next(m for topic, _, m in msgs if topic == topics.BIOTAC)
    assert first.hand_id == hand.name and [d.bt_serial for d in first.bt_data] == list(FINGERS)
    assert main(["import-bag", str(bag), "--topic", topics.BIOTAC, "--out", str(back)]) == 0
    assert back.read_bytes() == original.read_bytes()

    currents = np.stack([cols[f"current{j}"] for j in range(len(hand.joints))], axis=1)
    efforts = np.array([m.effort for topic, _, m in msgs if topic == topics.JOINT_STATES])
    assert efforts.shape == currents.shape and np.array_equal(efforts, currents)
    assert np.isfinite(currents).all() and np.abs(currents).max() > 0.01


def test_a_recording_round_trips_through_a_bag(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    original = tmp_path / "rec.csv"
    t0 = 1_712_345_678.0
    with FrameRecorder(original) as rec:
        for k in range(40):
            # the fingertips' frames arrive apart, two at the same time now and then
            t = [t0 + 0.01 * k + 0.000123 * i * (k % 3 != 0) for i in range(3)]
            rec.write(TactileFrame(i, k, t[i], rng.integers(0, 4096, 44)) for i in range(3))
    bag, back = tmp_path / "rec.mcap", tmp_path / "back.csv"
    assert main(["export-bag", str(original), "--out", str(bag), "--hand-id", "left_hand"]) == 0
    types, msgs, _ = _read(bag)
    assert list(types) == [topics.BIOTAC] and types[topics.BIOTAC][1] < 120  # shared times share a message
    assert all(m.hand_id == "left_hand" for _, _, m in msgs)
    assert main(["import-bag", str(bag), "--out", str(back)]) == 0
    assert back.read_bytes() == original.read_bytes()
    a, b = read_recording(original), read_recording(back)
    assert np.array_equal(a.t_ns, b.t_ns) and np.array_equal(a.values, b.values)


def test_run_mcap_writes_one_bag_per_trial(tmp_path: Path, capsys) -> None:
    out = tmp_path / "bags"
    assert _run(tmp_path / "run", trials=2, extra=("--mcap", str(out))) == 0
    assert "bags: 2 in" in capsys.readouterr().out
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*.mcap"))
    assert files == ["oracle/lego/trial_000.mcap", "oracle/lego/trial_001.mcap"]
    # a whole run directory exported: the same bags, an existing one refused without --force
    again = tmp_path / "again"
    assert main(["export-bag", str(tmp_path / "run"), "--out", str(again)]) == 0
    assert sorted(p.relative_to(again).as_posix() for p in again.rglob("*.mcap")) == files
    capsys.readouterr()
    assert main(["export-bag", str(tmp_path / "run"), "--out", str(again)]) == 2
    assert "--force" in capsys.readouterr().err


def _panels(node: object) -> list[str]:
    return [node] if isinstance(node, str) else [p for k in ("first", "second") for p in _panels(node[k])]


def test_the_foxglove_layout_shows_a_trial_bags_topics(trial: Path, tmp_path: Path) -> None:
    layout = json.loads((REPO / "docs" / "foxglove_trial_layout.json").read_text())
    assert sorted(_panels(layout["layout"])) == sorted(layout["configById"])
    shown = set()
    for config in layout["configById"].values():
        shown |= {p["value"].split(".")[0] for p in config.get("paths", [])}
        shown |= set(config.get("topics", {})) | ({config["topicPath"]} if "topicPath" in config else set())
    out = tmp_path / "trial.mcap"
    assert main(["export-bag", str(trial), "--out", str(out)]) == 0
    with AnyReader([out]) as reader:
        assert shown <= {c.topic for c in reader.connections}
        frames = {
            tr.child_frame_id
            for c, _, raw in reader.messages()
            if c.topic == topics.TF
            for tr in reader.deserialize(raw, c.msgtype).transforms
        }
    followed = {cfg.get("followTf") for cfg in layout["configById"].values()} - {None}
    assert followed <= frames | {"world"}


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_bad_input_is_one_line(trial: Path, tmp_path: Path, capsys, monkeypatch) -> None:
    assert main(["export-bag", str(trial), "--out", str(tmp_path / "x.bag")]) == 2
    assert ".mcap" in _one_error_line(capsys)
    (tmp_path / "x.mcap").write_bytes(b"")
    assert main(["export-bag", str(trial), "--out", str(tmp_path / "x.mcap")]) == 2
    assert "--force" in _one_error_line(capsys)
    (tmp_path / "notes.csv").write_text("a,b\n1,2\n")
    assert main(["export-bag", str(tmp_path / "notes.csv"), "--out", str(tmp_path / "y.mcap")]) == 2
    assert "not a trial" in _one_error_line(capsys)
    assert main(["export-bag", str(tmp_path / "nope.json"), "--out", str(tmp_path / "y.mcap")]) == 2
    assert "no such file" in _one_error_line(capsys)
    assert main(["export-bag", str(trial), "--out", str(tmp_path / "y.mcap"), "--hand-id", "left"]) == 2
    assert "--hand-id" in _one_error_line(capsys)
    assert main(["export-bag", str(trial.parents[3]), "--out", str(tmp_path / "y.mcap")]) == 2
    assert "give a folder" in _one_error_line(capsys)
    assert main(["export-bag", str(trial.parents[3]), "--out", "-"]) == 2
    assert "--out -" in _one_error_line(capsys) and not (tmp_path / "y.mcap").exists()
    assert _run(tmp_path / "r", extra=("--mcap", str(tmp_path / "m"), "--no-tick-logs")) == 2
    assert "--no-tick-logs" in _one_error_line(capsys) and not (tmp_path / "r").exists()
    monkeypatch.setitem(sys.modules, "mcap_ros2", None)  # the extra not installed
    assert main(["export-bag", str(trial), "--out", str(tmp_path / "z.mcap")]) == 2
    assert "pip install -e '.[ros]'" in _one_error_line(capsys)
    assert not (tmp_path / "z.mcap").exists()


def _copy_run(trial: Path, tmp_path: Path) -> Path:
    """A copy of the fixture's run (to damage); returns the copy's trial_000.json."""
    import shutil

    run_dir = tmp_path / "run"
    shutil.copytree(trial.parents[3], run_dir)
    return run_dir / trial.relative_to(trial.parents[3])


def test_a_trial_with_an_unreadable_record_is_refused_unless_forced(trial: Path, tmp_path: Path, capsys) -> None:
    copy = _copy_run(trial, tmp_path)
    text = copy.read_text()
    copy.write_text(text[: len(text) // 2])  # cut in half
    out = tmp_path / "cut.mcap"
    assert main(["export-bag", str(copy), "--out", str(out)]) == 2
    line = _one_error_line(capsys)
    assert f"{copy}: unreadable record" in line and "--force" in line and not out.exists()
    # a run directory: refused before any bag is written
    assert main(["export-bag", str(copy.parents[3]), "--out", str(tmp_path / "bags")]) == 2
    assert "unreadable record" in _one_error_line(capsys) and not (tmp_path / "bags").exists()

    assert main(["export-bag", str(copy), "--out", str(out), "--force"]) == 0
    err = capsys.readouterr().err
    assert f"note: {copy}: unreadable record" in err  # the loader's note, printed
    assert f"note: {out}: exported without its record: no {topics.TRIAL_EVENTS}" in err
    types, _, _ = _read(out)
    assert topics.TRIAL_EVENTS not in types and topics.TF in types


def _run_with_own_hand_file(trial: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A copy of the fixture's run whose run.json names a copy of the hand file (as ``run --hand
    COPY`` writes it: same bytes, so the same SHA-256); returns (trial_000.json, the hand file)."""
    copy = _copy_run(trial, tmp_path)
    hand = tmp_path / "hand.toml"
    hand.write_bytes(default_hand_file().read_bytes())
    run_file = copy.parents[3] / "run.json"
    doc = json.loads(run_file.read_text())
    doc["hand_file"] = doc["fingerprint"]["files"]["hand"]["path"] = str(hand)
    run_file.write_text(json.dumps(doc, indent=2))
    return copy, hand


def test_a_hand_file_edited_since_the_run_is_refused_without_hand_or_force(trial: Path, tmp_path: Path, capsys) -> None:
    copy, hand = _run_with_own_hand_file(trial, tmp_path)
    assert main(["export-bag", str(copy), "--out", str(tmp_path / "same.mcap")]) == 0  # unchanged: no word
    assert "note: hand" not in capsys.readouterr().err
    hand.write_text(hand.read_text() + "\n# tuned after the run\n")
    out = tmp_path / "edited.mcap"
    assert main(["export-bag", str(copy), "--out", str(out)]) == 2
    line = _one_error_line(capsys)
    assert f"hand ({hand}) changed since the run started" in line and "--hand FILE" in line and "--force" in line
    assert not out.exists()
    assert main(["export-bag", str(copy.parents[3]), "--out", str(tmp_path / "bags")]) == 2
    assert "changed since the run started" in _one_error_line(capsys)
    assert main(["export-bag", str(copy), "--out", str(out), "--force"]) == 0
    assert f"note: {out}: {topics.TF} from {hand}, not known to be the trial's hand" in capsys.readouterr().err
    assert (
        main(["export-bag", str(copy), "--out", str(tmp_path / "given.mcap"), "--hand", str(default_hand_file())]) == 0
    )
    assert "not known to be the trial's hand" not in capsys.readouterr().err


def test_an_unreadable_run_file_is_refused_without_hand_or_force(trial: Path, tmp_path: Path, capsys) -> None:
    copy = _copy_run(trial, tmp_path)
    (copy.parents[3] / "run.json").write_text('{"format": 1, "backend"')  # cut short
    out = tmp_path / "t.mcap"
    assert main(["export-bag", str(copy), "--out", str(out)]) == 2
    line = _one_error_line(capsys)
    assert "run.json: unreadable run file" in line and "--hand FILE" in line and not out.exists()
    assert main(["export-bag", str(copy), "--out", str(out), "--force"]) == 0
    err = capsys.readouterr().err
    assert "run.json: unreadable run file" in err and f"{topics.TF} from {default_hand_file()}" in err
    assert main(["export-bag", str(copy), "--out", str(tmp_path / "h.mcap"), "--hand", str(default_hand_file())]) == 0
