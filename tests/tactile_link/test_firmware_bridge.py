"""The reference sensor-bridge firmware (firmware/biotac_bridge), built for the host.

``make -C firmware/biotac_bridge host`` builds ``bridge_host``: the firmware's bridge
logic against simulated BioTacs (only SPI, timer and USB differ from the Teensy build).
These tests build it with the host C++ compiler (skipped when there is none), run the
C++ unit tests, check its stream and its SPI trace against protocol v1 and the BioTac's
documented command words, and read its real-time pseudo-terminal with the project's
own reader (``SerialSensors``).
"""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.files.paths import REPO_ROOT
from grasp_ctrl.tactile_link.decoder import BinaryDecoder, TextDecoder
from grasp_ctrl.tactile_link.protocol import SYNC

FW_DIR = REPO_ROOT / "firmware" / "biotac_bridge"
BRIDGE_HOST = FW_DIR / "build" / "bridge_host"

pytestmark = [
    pytest.mark.skipif(sys.platform == "win32", reason="the host build needs POSIX pseudo-terminals"),
    pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed"),
    pytest.mark.skipif(
        shutil.which(os.environ.get("CXX", "g++")) is None, reason="no C++ compiler (g++ or $CXX) found"
    ),
]

# The BioTac's sampling command bytes as SynTouch documents them (bit 7 set, channel
# index in bits 6..1, odd parity in bit 0), written out independently of the C++ code.
COMMANDS = {
    "pac": 0x80, "pdc": 0x83, "tac": 0x85, "tdc": 0x86,
    "e1": 0xA2, "e2": 0xA4, "e3": 0xA7, "e4": 0xA8, "e5": 0xAB, "e6": 0xAD, "e7": 0xAE,
    "e8": 0xB0, "e9": 0xB3, "e10": 0xB5, "e11": 0xB6, "e12": 0xB9, "e13": 0xBA, "e14": 0xBC,
    "e15": 0xBF, "e16": 0xC1, "e17": 0xC2, "e18": 0xC4, "e19": 0xC7,
}  # fmt: skip
CHANNEL_OF = {cmd: name for name, cmd in COMMANDS.items()}
# Position in the protocol v1 frame (e1..e19, pdc, pac1..pac22, tdc, tac).
PROTOCOL_INDEX = {**{f"e{i}": i - 1 for i in range(1, 20)}, "pdc": 19, "tdc": 42, "tac": 43}


def odd_parity(byte: int) -> bool:
    return byte.bit_count() % 2 == 1


def decode_reply(word: int) -> tuple[int, bool]:
    hi, lo = word >> 8, word & 0xFF
    return ((hi >> 1) << 5) | (lo >> 3), odd_parity(hi) and odd_parity(lo)


@pytest.fixture(scope="module")
def bridge_host() -> Path:
    proc = subprocess.run(["make", "-C", str(FW_DIR), "host"], check=False, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert BRIDGE_HOST.is_file()
    return BRIDGE_HOST


def run_host(exe: Path, *args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(exe), *args], check=False, capture_output=True, timeout=timeout)
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")
    return proc


def split_info(stream: bytes) -> tuple[list[str], bytes]:
    """The '#' start-up lines before the first frame, and the rest."""
    first = stream.find(SYNC)
    head = stream[: first if first >= 0 else len(stream)]
    lines = head.decode("ascii").splitlines()
    assert all(line.startswith("# ") for line in lines), lines
    return lines, stream[len(head) :]


def test_host_unit_tests_pass() -> None:
    proc = subprocess.run(["make", "-C", str(FW_DIR), "test"], check=False, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "all 14 tests passed" in proc.stdout


def test_teensy_layer_compiles_against_arduino_stand_ins() -> None:
    """Type-checks src/teensy/main.cpp (not a Teensy build: no Arm toolchain here)."""
    proc = subprocess.run(
        ["make", "-C", str(FW_DIR), "teensy-check"], check=False, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_600_valid_frames_and_the_spi_trace_shows_the_biotac_sampling(bridge_host: Path, tmp_path: Path) -> None:
    trace = tmp_path / "spi.txt"
    out = run_host(bridge_host, "--fingers", "4", "--samples", "150", "--trace-spi", str(trace)).stdout

    # The stream: '#' start-up lines, then 600 frames; the project's reader skips the lines.
    info, _ = split_info(out)
    assert info[0].startswith("# biotac_bridge ") and "4 sensors" in info[0]
    for f in range(4):
        assert f"# finger {f} (sensor {f}): BioTac serial BT-SIM-000{f}, firmware sim-1.0" in info
    dec = BinaryDecoder()
    frames = dec.feed(out)
    st = dec.stats
    assert len(frames) == 600 and st.frames == 600
    assert st.crc_errors == st.length_errors == st.range_errors == st.seq_gaps == 0
    assert st.bytes_discarded == sum(len(line) + 1 for line in info) and st.resyncs == 1
    assert dec.pending_bytes == 0
    by_finger: dict[int, list] = defaultdict(list)
    for fr in frames:
        assert fr.values.shape == (44,)  # n = 44 (the decoder accepts no other)
        by_finger[fr.finger].append(fr)
    assert sorted(by_finger) == [0, 1, 2, 3]
    for frs in by_finger.values():
        assert [fr.seq for fr in frs] == list(range(150))  # +1 per fingertip
    # The press profile moves pdc and the electrodes of finger 0 (pressed from 1.0 s on).
    v0 = np.array([fr.values for fr in by_finger[0]])
    assert np.ptp(v0[:, 19]) > 200 and np.ptp(v0[:, 8]) > 100 and np.ptp(v0[:, 20:42]) > 50

    # The trace: one line per 16-bit transfer, '<sensor> <mosi> <miso>' ('#' = 8-bit start-up).
    lines = trace.read_text().splitlines()
    words = [
        tuple(int(x, 16) if i else int(x) for i, x in enumerate(ln.split())) for ln in lines if not ln.startswith("#")
    ]
    assert all(len(w) == 3 for w in words)
    for f in range(4):
        # start-up: serial number (0x15) and firmware version (0x13) read commands
        mine = [(mosi, miso) for s, mosi, miso in words if s == f]
        assert mine[0][0] == 0x6115 and mine[1][0] == 0x6113
        cmds = [mosi >> 8 for mosi, _ in mine[2:] if mosi != 0]
        reads = [miso for mosi, miso in mine[2:] if mosi == 0]
        assert all(mosi & 0xFF == 0 for mosi, _ in mine[2:])
        assert len(cmds) >= 150 * 44 and len(reads) == 150 * 44
        assert all(c in CHANNEL_OF for c in cmds), "only documented sampling commands"
        for k, fr in enumerate(by_finger[f]):
            names = [CHANNEL_OF[c] for c in cmds[44 * k : 44 * (k + 1)]]
            assert names.count("pac") == 22 and names[1::2] == ["pac"] * 22
            assert sorted(names[0::2]) == sorted(n for n in COMMANDS if n != "pac")  # each other channel once
            # Each reply decodes (odd parity, 12-bit layout) to the value in the sent frame.
            rebuilt = np.zeros(44, dtype=np.int64)
            pac = 0
            for name, word in zip(names, reads[44 * k : 44 * (k + 1)]):
                value, ok = decode_reply(word)
                assert ok
                if name == "pac":
                    rebuilt[20 + pac] = value
                    pac += 1
                else:
                    rebuilt[PROTOCOL_INDEX[name]] = value
            np.testing.assert_array_equal(rebuilt, fr.values)


def test_both_read_timings_give_the_same_stream(bridge_host: Path) -> None:
    same_tick = run_host(bridge_host, "--fingers", "4", "--samples", "50").stdout
    next_tick = run_host(bridge_host, "--fingers", "4", "--samples", "50", "--read-next-tick").stdout
    assert same_tick == next_tick and len(same_tick) > 200 * 96


def test_a_sensor_that_does_not_answer_is_named_and_sends_nothing(bridge_host: Path) -> None:
    proc = run_host(bridge_host, "--fingers", "3", "--samples", "20", "--absent", "1")
    info, _ = split_info(proc.stdout)
    assert any(line.startswith("# finger 1 (sensor 1): no answer") for line in info)
    assert b"finger 1: no answer" in proc.stderr
    dec = BinaryDecoder()
    frames = dec.feed(proc.stdout)
    assert sorted({fr.finger for fr in frames}) == [0, 2] and len(frames) == 40
    assert dec.stats.crc_errors == 0


def test_text_mode_carries_the_same_values(bridge_host: Path) -> None:
    binary = BinaryDecoder().feed(run_host(bridge_host, "--fingers", "2", "--samples", "10").stdout)
    out = run_host(bridge_host, "--fingers", "2", "--samples", "10", "--text").stdout
    dec = TextDecoder()
    text = dec.feed(out)
    assert len(text) == 20
    assert [(f.finger, f.seq) for f in text] == [(f.finger, f.seq) for f in binary]
    for a, b in zip(text, binary):
        np.testing.assert_array_equal(a.values, b.values)
    # The text reader skips the 3 '#' lines (the start-up report); nothing else is lost.
    assert dec.stats.format_errors == 0 and dec.stats.length_errors == 0 and dec.stats.range_errors == 0


def test_bad_arguments_are_refused(bridge_host: Path) -> None:
    for args in (
        ["--fingers", "0", "--samples", "1"],
        ["--fingers", "2"],
        ["--fingers", "9", "--samples", "1"],
        ["--fingers", "2", "--samples", "1", "--pty"],
        ["--bogus"],
    ):
        proc = subprocess.run([str(bridge_host), *args], check=False, capture_output=True, timeout=30)
        assert proc.returncode == 2, args


def start_pty(exe: Path, *args: str) -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen([str(exe), "--pty", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 10.0)
    assert ready, "bridge_host printed no pty path"
    path = proc.stdout.readline().decode().strip()
    assert path.startswith("/dev/"), path
    return proc, path


def test_pty_stream_read_by_serial_sensors_at_100hz(bridge_host: Path) -> None:
    from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

    tips = (0, 1, 2, 3)
    proc, path = start_pty(bridge_host, "--fingers", "4", "--seconds", "5")
    try:
        with SerialSensors({path: tips}, keep_history=10_000) as sens:
            sens.wait_for_frames(5.0)
            time.sleep(0.3)
            sens.drain_frames()
            t0 = time.monotonic()
            time.sleep(3.0)
            frames = sens.drain_frames()
            t1 = time.monotonic()
            stats = sens.stats()
    finally:
        proc.wait(timeout=15)
    err = proc.stderr.read().decode() if proc.stderr else ""
    assert proc.returncode == 0, err
    for tip in tips:
        mine = [f for f in frames if f.sensor_id == tip]
        rate = len(mine) / (t1 - t0)
        assert 90.0 <= rate <= 110.0, (tip, rate)
    assert stats["crc_errors"] == stats["length_errors"] == stats["range_errors"] == 0
    assert stats["seq_gaps"] == 0 and stats["unexpected_sensor_frames"] == 0
    assert stats["resyncs"] <= 1  # the '#' start-up report, sent when the port was opened
    # (frames sent after the reader closed the port fill the pty and are then dropped)


def test_pty_never_blocks_when_the_host_stops_reading(bridge_host: Path) -> None:
    """The port is open but nobody reads for 3 s: the pty fills, the bridge drops whole
    frames (seq shows the gap) and keeps its schedule; what the reader gets is intact."""
    t_start = time.monotonic()
    proc, path = start_pty(bridge_host, "--fingers", "4", "--seconds", "4.5")
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            time.sleep(3.0)  # open, not reading
            data = bytearray()
            while proc.poll() is None:
                select.select([fd], [], [], 0.1)
                try:
                    data += os.read(fd, 65536)
                except BlockingIOError:
                    pass
                except OSError:
                    break
        finally:
            os.close(fd)
    finally:
        proc.wait(timeout=15)
    elapsed = time.monotonic() - t_start
    err = proc.stderr.read().decode() if proc.stderr else ""
    assert proc.returncode == 0 and elapsed < 8.0, (elapsed, err)
    dropped = int(err.split("dropped ")[1].split(" ")[0])
    assert dropped > 0, err
    info, _ = split_info(bytes(data))  # the start-up report came first, when the port was opened
    assert len(info) == 5
    dec = BinaryDecoder()
    frames = dec.feed(bytes(data))
    assert len(frames) > 400
    assert dec.stats.crc_errors == 0 and dec.stats.length_errors == 0
    assert dec.stats.seq_gaps >= 4 and dec.stats.seq_lost > 0  # a gap per fingertip at least


def test_bridge_info_tool_shows_the_report_and_names_a_silent_sensor(bridge_host: Path) -> None:
    proc, path = start_pty(bridge_host, "--fingers", "3", "--absent", "1", "--seconds", "3")
    try:
        tool = subprocess.run(
            [sys.executable, str(FW_DIR / "tools" / "bridge_info.py"), path, "--seconds", "1"],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
        )
    finally:
        proc.wait(timeout=15)
    assert tool.returncode == 0, tool.stderr
    out = tool.stdout
    assert "# finger 0 (sensor 0): BioTac serial BT-SIM-0000, firmware sim-1.0" in out
    assert "# finger 1 (sensor 1): no answer" in out
    assert "# stats: built " in out
    assert "finger 0: " in out and "finger 2: " in out and "finger 1: " not in out.splitlines()[-1]


def test_host_can_switch_the_bridge_to_text_mode(bridge_host: Path) -> None:
    proc, path = start_pty(bridge_host, "--fingers", "2", "--seconds", "2")
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            time.sleep(0.3)
            os.write(fd, b"t")
            time.sleep(0.2)
            while True:  # drop what was sent before the switch
                try:
                    os.read(fd, 65536)
                except BlockingIOError:
                    break
            data = bytearray()
            deadline = time.monotonic() + 0.5
            while time.monotonic() < deadline:
                select.select([fd], [], [], 0.05)
                try:
                    data += os.read(fd, 65536)
                except BlockingIOError:
                    pass
        finally:
            os.close(fd)
    finally:
        proc.wait(timeout=15)
    dec = TextDecoder()
    frames = dec.feed(bytes(data))
    assert len(frames) >= 60 and {f.finger for f in frames} == {0, 1}
    assert dec.stats.length_errors <= 1 and dec.stats.range_errors == 0  # at most the cut first line
