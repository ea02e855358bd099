"""Show what a BioTac bridge reports about itself: its start-up report (firmware,
each sensor's serial number and firmware version, sensors that do not answer) and its
statistics, plus the frames per fingertip it streamed meanwhile.

    python firmware/biotac_bridge/tools/bridge_info.py /dev/ttyACM0 [--seconds 1] [--mode binary]

It opens the port (the bridge sends its report when a host opens the port; if none
comes within 0.3 s it asks for it with 'i'), asks for the statistics ('s') and prints
every '#' line it receives. Works on the bridge's real-time host build too
(``bridge_host --pty``). Close ``python launch.py sensors`` first: a port has one reader.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))

import serial

from grasp_ctrl.tactile_link.decoder import make_decoder

INFO_LINE = re.compile(rb"# [\x20-\x7e]*\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("port", help="serial port of the bridge, e.g. /dev/ttyACM0")
    ap.add_argument("--seconds", type=float, default=1.0, help="how long to listen (default 1)")
    ap.add_argument("--mode", choices=("binary", "text"), default="binary", help="protocol mode the bridge sends")
    ap.add_argument("--baud", type=int, default=1_000_000, help="baud (nominal on USB; default 1000000)")
    args = ap.parse_args(argv)

    try:
        ser = serial.serial_for_url(args.port, baudrate=args.baud, timeout=0.05)
    except serial.SerialException as exc:
        print(f"cannot open {args.port}: {exc}", file=sys.stderr)
        return 1
    data = bytearray()
    with ser:
        deadline = time.monotonic() + args.seconds
        t_ask = time.monotonic() + 0.3
        while time.monotonic() < t_ask:
            data += ser.read(65536)
        ser.write(b"s" if b"# biotac_bridge " in data else b"is")
        while time.monotonic() < deadline:
            data += ser.read(65536)
    for m in INFO_LINE.finditer(bytes(data)):
        print(m.group().decode("ascii").rstrip("\n"))
    dec = make_decoder(args.mode)
    frames = dec.feed(bytes(data))
    per_finger = Counter(f.finger for f in frames)
    got = ", ".join(f"finger {k}: {v}" for k, v in sorted(per_finger.items())) or "none"
    print(f"frames in {args.seconds:g} s: {got}; crc errors {dec.stats.crc_errors}")
    return 0 if data else 1


if __name__ == "__main__":
    sys.exit(main())
