"""``sensors``: live monitor of the tactile fingertips over the serial link."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

NAME = "sensors"
HELP = "live monitor of the tactile fingertips (serial protocol v1); can record frames to CSV"
DESCRIPTION = (
    "Opens the tactile port(s) of the hand file, tares every fingertip (keep them free of "
    "contact for the first second), then shows per fingertip the contact state, tared pdc, "
    "frame age and rate, the estimated force f_sensor (when the policy loads) and the stream "
    "statistics (CRC errors, resyncs, sequence gaps, disconnects). Ctrl-C stops cleanly. "
    "--emulate runs against a built-in emulator of the sensor bridge instead of hardware. "
    "Protocol: docs/tactile_protocol.md."
)
ORDER = 40


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file

    add_hand_file(p, resolved=False)
    p.add_argument("--port", metavar="PORT", help="read every fingertip from this one port (overrides the hand file)")
    p.add_argument("--mode", choices=("binary", "text"), help="protocol mode (default: the hand file's)")
    p.add_argument("--baud", type=int, metavar="N", help="baud rate (default: the hand file's)")
    p.add_argument(
        "--record",
        metavar="FILE",
        help="write every valid frame to this CSV file (opened once the ports are; an existing file is "
        "replaced only with --force, never the --emulate-from input)",
    )
    p.add_argument("--force", action="store_true", help="with --record: replace an existing file")
    p.add_argument(
        "--seconds", type=float, metavar="S", help="stop after S seconds of monitoring (default: until Ctrl-C)"
    )
    p.add_argument("--policy", metavar="NAME", help="force estimator policy (default: the default policy)")
    p.add_argument(
        "--refresh", type=float, default=0.5, metavar="S", help="seconds between table updates (default 0.5)"
    )
    p.add_argument("--no-reconnect", action="store_true", help="do not reopen an unplugged port")
    emu = p.add_argument_group("emulator (no hardware needed)")
    emu.add_argument(
        "--emulate", action="store_true", help="stream from a built-in sensor-bridge emulator on a pseudo-terminal"
    )
    emu.add_argument(
        "--skip-bad-rows",
        action="store_true",
        help="with --emulate-from: leave out rows that are short, not numbers or out of range "
        "(counted on stderr) instead of stopping at the first",
    )
    emu.add_argument(
        "--emulate-from",
        metavar="CSV",
        help="replay this recording (columns pdc, e1..e19) instead of synthetic presses",
    )
    emu.add_argument(
        "--emulate-corrupt", type=float, default=0.0, metavar="P", help="probability of a corrupted frame (bit flips)"
    )


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.errors import PolicyError, UsageError
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY, load_policy
    from grasp_ctrl.files.paths import default_hand_file
    from grasp_ctrl.tactile_link.monitor import Monitor
    from grasp_ctrl.tactile_link.recorder import FrameRecorder
    from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

    if args.seconds is not None and args.seconds < 0:
        raise UsageError(f"--seconds: a value >= 0 (got {args.seconds})")
    if args.refresh <= 0:
        raise UsageError(f"--refresh: a value > 0 (got {args.refresh})")
    if args.baud is not None and args.baud < 300:
        raise UsageError(f"--baud: a baud rate >= 300 (got {args.baud})")
    if not 0.0 <= args.emulate_corrupt <= 1.0:
        raise UsageError(f"--emulate-corrupt: a probability 0..1 (got {args.emulate_corrupt})")
    if args.emulate and args.port:
        raise UsageError("--port and --emulate exclude each other (the emulator makes its own port)")
    if (args.emulate_from or args.emulate_corrupt) and not args.emulate:
        raise UsageError("--emulate-from/--emulate-corrupt need --emulate")
    if args.record:
        check_record(Path(args.record), args.emulate_from, args.force)

    hand = load_hand(args.hand or default_hand_file())
    mode = args.mode or hand.tactile.mode

    try:
        estimator = load_policy(args.policy or DEFAULT_POLICY, hand)
    except PolicyError as exc:
        if args.policy:
            raise
        print(f"note: no force column ({exc})", file=sys.stderr)
        estimator = None

    emulator = None
    port = args.port
    if args.emulate:
        emulator = _make_emulator(hand, mode, args.emulate_from, args.emulate_corrupt, args.skip_bad_rows)
        port = emulator.port

    kwargs: dict = {"mode": mode, "keep_history": 1_000_000}
    if args.baud:
        kwargs["baud"] = args.baud
    if args.no_reconnect:
        kwargs["reconnect"] = False
    sensors = SerialSensors.from_hand(hand, port=port, **kwargs)
    recorder = None
    try:
        sensors.start()
        if emulator is not None:
            emulator.start()
        # opened only now that the ports are: a bad --port leaves an existing file as it was (the
        # frames received meanwhile wait in the sensors' history, which the monitor drains)
        recorder = FrameRecorder(args.record) if args.record else None
        monitor = Monitor(hand, sensors, estimator, recorder, refresh_s=args.refresh, redraw=sys.stdout.isatty())
        print(
            f"taring {len(hand.fingers)} fingertips on {', '.join(sensors.port_status())} "
            f"({hand.tactile.tare_frames} frames, keep them free of contact) ...",
            flush=True,
        )
        with _ctrl_c_sets(monitor.stop):
            monitor.take_tare()
            monitor.run(args.seconds)
        if monitor.stop.is_set():
            print("stopped (Ctrl-C)", flush=True)
        print(f"done: {monitor.stats_line()}", flush=True)
        if recorder is not None:
            print(f"recorded {recorder.rows} frames to {recorder.path}", flush=True)
    finally:
        sensors.close()
        if recorder is not None:
            recorder.close()
        if emulator is not None:
            emulator.close()
    return 0


def check_record(record: Path, emulate_from: str | None, force: bool) -> None:
    """``--record``: never the ``--emulate-from`` input (not even with --force: the replay reads
    it), never a run's own file, an existing file replaced only with --force."""
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.safe_write import check_new_file, check_output, same_file

    if emulate_from and same_file(record, Path(emulate_from)):
        raise UsageError(f"--record {record}: that is the --emulate-from recording being replayed; choose another file")
    check_output(record, "--record")
    check_new_file(record, "--record", force)


def _make_emulator(hand, mode: str, recording: str | None, corrupt: float, skip_bad_rows: bool = False):
    from grasp_ctrl.emulators.tactile_bridge import FaultConfig, RecordingSource, TactileBridgeEmulator
    from grasp_ctrl.errors import UsageError

    source = None
    if recording:
        try:
            source = RecordingSource(Path(recording), skip_bad_rows=skip_bad_rows)
        except (OSError, ValueError) as exc:
            raise UsageError(f"--emulate-from {recording}: {exc}") from None
    return TactileBridgeEmulator(
        [f.sensor_id for f in hand.fingers],
        source,
        rate_hz=hand.rate_hz,
        mode=mode,
        faults=FaultConfig(corrupt_prob=corrupt),
    )


@contextlib.contextmanager
def _ctrl_c_sets(event: threading.Event) -> Iterator[None]:
    """First Ctrl-C sets ``event`` (the monitor finishes its loop, every frame drained is
    written and the CSV is closed); a second one interrupts as usual."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: object) -> None:
        event.set()
        signal.signal(signal.SIGINT, previous)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
