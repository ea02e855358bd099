"""``import-bag``: BioTacHand messages of ROS 1 and ROS 2 bags (written here with rosbags) into the
tactile recording format, with force labels from a wrench topic (skipped without the ros extra)."""

from __future__ import annotations

import contextlib
import json
import sqlite3
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mcap")
pytest.importorskip("mcap_ros2")
pytest.importorskip("rosbags")

from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import get_types_from_msg

from grasp_ctrl.bags.recording import read_recording
from grasp_ctrl.bags.types import BIOTAC_HAND, BIOTAC_HAND_ROS1_MD5, typestore
from grasp_ctrl.cli import main
from grasp_ctrl.config.sensor_layout import BIOTAC
from grasp_ctrl.estimators.linear import fit_linear
from grasp_ctrl.hardware.base import TactileFrame
from grasp_ctrl.learning.synthetic import generate, generate_trials
from grasp_ctrl.tactile_link.recorder import FrameRecorder

T0_NS = 1_712_345_678_000_000_000  # an epoch time: beyond a float's integers in ns
TOPIC = "/biotac_pub"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"

# (t_ns, [(bt_position, 44 counts)]) per BioTacHand message
Frames = list[tuple[int, list[tuple[int, np.ndarray]]]]
# topic -> (type, [(t_ns, build(store, ros1) -> message)])
Topics = dict[str, tuple[str, list[tuple[int, Callable]]]]


def _hand(frames: list[tuple[int, np.ndarray]], t_ns: int, k: int) -> Callable:
    def build(store, ros1: bool):  # type: ignore[no-untyped-def]
        T = store.types
        time = T["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
        head = {"seq": k} if ros1 else {}
        data = [
            T["biotac_sensors/msg/BioTacData"](
                bt_serial=f"BT-{p:04d}",
                bt_position=p,
                tdc_data=int(v[BIOTAC.tdc]),
                tac_data=int(v[BIOTAC.tac]),
                pdc_data=int(v[BIOTAC.pdc]),
                pac_data=np.asarray(v[BIOTAC.pac], dtype=np.uint16),
                electrode_data=np.asarray(v[BIOTAC.electrodes], dtype=np.uint16),
            )
            for p, v in frames
        ]
        bt_time = T["biotac_sensors/msg/BioTacTime"](
            frame_start_time=time,
            frame_end_time=time,
            tdc_ns_offset=0,
            tac_ns_offset=0,
            pdc_ns_offset=0,
            pac_ns_offset=np.zeros(22, np.uint32),
            electrode_ns_offset=np.zeros(19, np.uint32),
        )
        return T[BIOTAC_HAND](
            header=T["std_msgs/msg/Header"](**head, stamp=time, frame_id=""),
            hand_id="left_hand",
            bt_data=data,
            bt_time=bt_time,
        )

    return build


def _wrench(t_ns: int, f: np.ndarray, frame_id: str = "ft_link") -> Callable:
    def build(store, ros1: bool):  # type: ignore[no-untyped-def]
        T = store.types
        time = T["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
        head = {"seq": 0} if ros1 else {}
        v3 = T["geometry_msgs/msg/Vector3"]
        return T[WRENCH_STAMPED](
            header=T["std_msgs/msg/Header"](**head, stamp=time, frame_id=frame_id),
            wrench=T["geometry_msgs/msg/Wrench"](force=v3(x=f[0], y=f[1], z=f[2]), torque=v3(x=0.0, y=0.0, z=0.0)),
        )

    return build


def _topics(frames: Frames, wrenches: list[tuple[int, np.ndarray]] = ()) -> Topics:
    out: Topics = {TOPIC: (BIOTAC_HAND, [(t, _hand(fr, t, k)) for k, (t, fr) in enumerate(frames)])}
    if wrenches:
        out["/ft/wrench"] = (WRENCH_STAMPED, [(t, _wrench(t, f)) for t, f in wrenches])
    return out


def write_bag(path: Path, content: Topics, storage: str = "ros1") -> Path:
    """A ROS 1 .bag, or a ROS 2 bag folder (storage "mcap" or "sqlite3"); returns what to import."""
    ros1 = storage == "ros1"
    store = typestore(1 if ros1 else 2)
    items = sorted((t, topic, build) for topic, (_, msgs) in content.items() for t, build in msgs)
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer:
        conns = {topic: writer.add_connection(topic, kind, typestore=store) for topic, (kind, _) in content.items()}
        for t, topic, build in items:
            msg = build(store, ros1)
            kind = content[topic][0]
            data = store.serialize_ros1(msg, kind) if ros1 else store.serialize_cdr(msg, kind)
            writer.write(conns[topic], t, data)
    return path


def _driver_frames(n: int = 30, positions: tuple[int, ...] = (1, 2, 3), seed: int = 1) -> Frames:
    """Messages of the driver: every BioTac's frame each 10 ms, stamps with sub-microsecond parts."""
    rng = np.random.default_rng(seed)
    return [(T0_NS + k * 10_000_000 + 4321, [(p, rng.integers(0, 4096, 44)) for p in positions]) for k in range(n)]


def _recorder_file(path: Path, frames: Frames) -> Path:
    """What the project's own recorder writes for the same frames (seq: each fingertip's count)."""
    seq: dict[int, int] = {}
    with FrameRecorder(path) as rec:
        for t, fr in frames:
            for p, v in fr:
                rec.write([TactileFrame(p, seq.get(p, 0), t / 10**9, v)])
                seq[p] = seq.get(p, 0) + 1
    return path


def test_the_driver_definition_is_registered() -> None:
    text, md5 = typestore(1).generate_msgdef(BIOTAC_HAND, ros_version=1)
    assert md5 == BIOTAC_HAND_ROS1_MD5 and "uint16[19] electrode_data" in text


@pytest.mark.parametrize("storage", ["ros1", "mcap", "sqlite3"])
def test_bags_import_to_the_recording_the_recorder_writes(tmp_path: Path, storage: str, capsys) -> None:
    frames = _driver_frames()
    expected = _recorder_file(tmp_path / "expected.csv", frames)
    bag = write_bag(tmp_path / ("driver.bag" if storage == "ros1" else "driver"), _topics(frames), storage)
    if storage == "sqlite3":  # as ROS 2 Humble records: no message definitions in the file
        db = next(bag.glob("*.db3"))
        with contextlib.closing(sqlite3.connect(db)) as con, con:
            con.execute("DELETE FROM message_definitions")
    sources = [bag]
    if storage != "ros1":  # the folder, and its one storage file on its own
        sources.append(next(bag.glob("*.mcap" if storage == "mcap" else "*.db3")))
    for i, source in enumerate(sources):
        out = tmp_path / f"imported{i}.csv"
        assert main(["import-bag", str(source), "--out", str(out)]) == 0
        assert "90 frames" in capsys.readouterr().out
        assert out.read_bytes() == expected.read_bytes()
        rec, ref = read_recording(out), read_recording(expected)
        assert [f.sensor_id for f in rec.frames()] == [f.sensor_id for f in ref.frames()]
        assert np.array_equal(rec.values, ref.values) and np.array_equal(rec.t_ns, ref.t_ns)


def test_a_variant_definition_reads_by_the_bags_own(tmp_path: Path) -> None:
    """A BioTacHand declared with unbounded arrays and no bt_time (a port of the driver): the bag's
    definition is used, the frames are the same."""
    store = typestore(1)
    variant = {
        BIOTAC_HAND: "Header header\nstring hand_id\nbiotac_sensors/BioTacData[] bt_data\n",
        "biotac_sensors/msg/BioTacData": (
            "string bt_serial\nuint8 bt_position\nuint16 tdc_data\nuint16 tac_data\nuint16 pdc_data\n"
            "uint16[] pac_data\nuint16[] electrode_data\n"
        ),
    }
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    for name, text in variant.items():
        store.register(get_types_from_msg(text, name))
    frames = _driver_frames(5, (0,))
    T = store.types
    with Writer1(tmp_path / "v.bag") as w:
        conn = w.add_connection(TOPIC, BIOTAC_HAND, typestore=store)
        for k, (t, fr) in enumerate(frames):
            (p, v) = fr[0]
            data = T["biotac_sensors/msg/BioTacData"](
                bt_serial="x",
                bt_position=p,
                tdc_data=int(v[BIOTAC.tdc]),
                tac_data=int(v[BIOTAC.tac]),
                pdc_data=int(v[BIOTAC.pdc]),
                pac_data=np.asarray(v[BIOTAC.pac], np.uint16),
                electrode_data=np.asarray(v[BIOTAC.electrodes], np.uint16),
            )
            stamp = T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)
            msg = T[BIOTAC_HAND](
                header=T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id=""), hand_id="", bt_data=[data]
            )
            w.write(conn, t, store.serialize_ros1(msg, BIOTAC_HAND))
    out = tmp_path / "v.csv"
    assert main(["import-bag", str(tmp_path / "v.bag"), "--out", str(out)]) == 0
    assert out.read_bytes() == _recorder_file(tmp_path / "ref.csv", frames).read_bytes()


def _labelled_bags(tmp_path: Path) -> list[Path]:
    """Two bags of presses of the simulated BioTac, each a trial of several presses: the frames at
    100 Hz and the force on the sensor (sensor frame, N) from a force/torque sensor 3 ms later.
    Each simulated press starts from its own rest signals: they are moved onto the first one's,
    as one sensor's stream would be."""
    presses = generate_trials(1500, seed=4, sources=("rigid-ft",))
    rest = None
    bags = []
    for i, group in enumerate((presses[::2], presses[1::2])):
        raws, forces = [], []
        for press in group:
            rows = press.raw_rows()
            own = rows.raw[rows.t < 0].mean(axis=0)  # its contact-free start
            rest = own if rest is None else rest
            raws.append(rows.raw - own + rest)
            forces.append(np.nan_to_num(rows.f_sensor))
        raw = np.clip(np.rint(np.vstack(raws)), 0, 4095).astype(np.int64)
        f = np.vstack(forces)
        t_ns = T0_NS + 10_000_000 * np.arange(len(raw))
        frames = [(int(t), [(0, raw[k])]) for k, t in enumerate(t_ns)]
        wrenches = [(int(t) + 3_000_000, f[k]) for k, t in enumerate(t_ns)]
        bags.append(write_bag(tmp_path / f"presses{i}.bag", _topics(frames, wrenches)))
    return bags


def _base_policy(path: Path) -> Path:
    """A linear policy for the simulated BioTac (as calibrate's own tests make one)."""
    nominal = generate(3000, seed=11, sources=("rigid-ft",))
    w, b = fit_linear(nominal.tared, nominal.f_sensor)
    doc = {"name": path.stem, "kind": "linear", "sensor_type": "biotac", "has_variance": False}
    path.write_text(json.dumps({**doc, "weights_n_per_count": w.tolist(), "bias_n": b.tolist()}))
    return path


def test_labelled_bags_feed_evaluate_direction_calibrate_and_sensors(tmp_path: Path, capsys, monkeypatch) -> None:
    bags = _labelled_bags(tmp_path)
    rec = tmp_path / "presses.csv"
    assert main(["import-bag", *map(str, bags), "--out", str(rec), "--wrench", "/ft/wrench"]) == 0
    out = capsys.readouterr().out
    assert "labels from /ft/wrench in frame 'ft_link'" in out and "1 frames outside its time span left out" in out
    header = rec.read_text().splitlines()[0].split(",")
    assert header[-8:] == ["trial_id", "fx", "fy", "fz", "nx", "ny", "nz", "in_paper_trial"]

    base = _base_policy(tmp_path / "base_lin.json")
    result = tmp_path / "direction.json"
    argv = ["evaluate-direction", "--data", str(rec), "--estimators", f"policy:{base}", "--tare-frames", "15"]
    assert main([*argv, "--json", str(result)]) == 0
    pooled = json.loads(result.read_text())["pooled"][f"policy:{base}"]
    print(f"imported presses: median direction error {pooled['median_deg']:.1f} deg over {pooled['n_test']} frames")
    assert pooled["n_test"] > 1000 and pooled["median_deg"] < 15.0  # the labels are the presses' forces

    cal = tmp_path / "base_lin_presses.json"
    argv = ["calibrate", "--data", str(rec), "--policy", str(base), "--out", str(cal), "--model", "gains"]
    assert main([*argv, "--tare-frames", "15"]) == 0
    assert json.loads(cal.read_text())["kind"] == "calibrated"

    if sys.platform != "win32":  # the sensor-bridge emulator replays it (on a POSIX pseudo-terminal)
        monkeypatch.setenv("GRASP_CTRL_POLICIES", str(tmp_path / "no_policies"))  # no force column: faster
        capsys.readouterr()
        assert main(["sensors", "--emulate", "--emulate-from", str(rec), "--seconds", "1.2", "--refresh", "0.5"]) == 0
        assert "done:" in capsys.readouterr().out


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_bad_bags_are_one_line(tmp_path: Path, capsys, monkeypatch) -> None:
    out = str(tmp_path / "out.csv")
    good = write_bag(
        tmp_path / "good.bag", _topics(_driver_frames(10), [(T0_NS, np.zeros(3)), (T0_NS + 1, np.ones(3))])
    )

    def fails(argv: list[str], *words: str) -> None:
        assert main(["import-bag", *argv, "--out", out]) == 2
        line = _one_error_line(capsys)
        assert all(w in line for w in words), line
        assert not Path(out).exists()

    only_wrench = {"/ft/wrench": (WRENCH_STAMPED, [(T0_NS, _wrench(T0_NS, np.zeros(3)))])}
    fails([str(write_bag(tmp_path / "ft.bag", only_wrench))], "no biotac_sensors/BioTacHand topic", "/ft/wrench")
    fails([str(good), "--topic", "/nope"], "--topic /nope", "not in")
    fails([str(good), "--topic", "/ft/wrench"], "geometry_msgs/WrenchStamped", "not biotac_sensors/BioTacHand")
    fails([str(good), "--wrench", "/biotac_pub"], "--wrench", "not geometry_msgs/WrenchStamped")
    fails([str(good), "--wrench", "/ft/wrench"], "--finger")
    fails([str(good), "--finger", "7"], "--finger 7")
    fails([str(good), "--min-force", "1"], "only with --wrench")
    # truncated files, a text file, a missing one
    data = good.read_bytes()
    (tmp_path / "cut.bag").write_bytes(data[: len(data) // 2])
    fails([str(tmp_path / "cut.bag")], "cut.bag", "not a readable bag")
    ros2 = write_bag(tmp_path / "r2", _topics(_driver_frames(10)), "mcap")
    mcap = next(ros2.glob("*.mcap"))
    (tmp_path / "cut.mcap").write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    fails([str(tmp_path / "cut.mcap")], "cut.mcap")
    (tmp_path / "notes.txt").write_text("hello\n")
    fails([str(tmp_path / "notes.txt")], "not a bag")
    fails([str(tmp_path / "nope.bag")], "no such bag")
    # a count beyond 12 bits
    big = _driver_frames(2, (0,))
    big[1][1][0][1][5] = 5000
    fails([str(write_bag(tmp_path / "big.bag", _topics(big)))], "5000", "12-bit")
    # the output: a bag's extension, an existing file
    assert main(["import-bag", str(good), "--out", str(tmp_path / "x.parquet")]) == 2
    assert ".csv" in _one_error_line(capsys)
    Path(out).write_text("")
    assert main(["import-bag", str(good), "--out", out]) == 2
    assert "--force" in _one_error_line(capsys)
    assert main(["import-bag", str(good), "--out", out, "--force"]) == 0
    capsys.readouterr()
    monkeypatch.setitem(sys.modules, "rosbags", None)  # the extra not installed
    assert main(["import-bag", str(good), "--out", out, "--force"]) == 2
    assert "pip install -e '.[ros]'" in _one_error_line(capsys)
