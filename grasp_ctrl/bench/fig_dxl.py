"""``dxl_cycle_16_ms``: one sync read + one sync write of the 16-servo LEAP Hand.

The servo chain is the Protocol 2.0 emulator, run in its own process (like
the real bus, it must not share this interpreter's GIL) behind a pty, driven
by ``DynamixelHand`` through dynamixel_sdk exactly as in a control tick.
``dxl_cycle_16_plain_ms`` is the same cycle with the plain Sync Read fallback
(one status packet per servo) for comparison. The emulator is a user-space
process on a shared host, not a servo answering in microseconds, so the bench
allows it a 50 ms reply deadline and 5 retries instead of the hand file's 8 ms
and 2: a scheduling hiccup then shows in p99 instead of aborting the bench.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from grasp_ctrl.bench.figure import Figure, time_ms
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.files.paths import REPO_ROOT, default_hand_file


@contextmanager
def emulator_process(hand_file: str) -> Iterator[str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "grasp_ctrl.emulators.dxl_chain", "--hand", hand_file],
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO_ROOT,
    )
    try:
        assert proc.stdout is not None
        port = proc.stdout.readline().strip()
        if not port:
            raise RuntimeError("the Dynamixel emulator did not start")
        yield port
    finally:
        proc.terminate()
        proc.wait(timeout=5)


def _cycle(quick: bool, fast: bool) -> Figure:
    from grasp_ctrl.hardware.dynamixel import DynamixelHand

    hand_file = str(default_hand_file())
    hand = load_hand(hand_file)
    hand = dataclasses.replace(
        hand,
        dynamixel=dataclasses.replace(hand.dynamixel, fast_sync_read=fast, packet_timeout_ms=50.0, retries=5),
    )
    q = np.array([j.pregrasp_rad for j in hand.joints])
    with emulator_process(hand_file) as port:
        dxl = DynamixelHand(hand, port, handle_signals=False)
        dxl.connect()
        try:
            assert dxl.bus.fast_sync_read == fast

            def tick() -> None:
                dxl.read()
                dxl.write_goals(q)

            return time_ms(tick, repeats=200 if quick else 2000, warmup=20)
        finally:
            dxl.safe_stop("torque_off")
            dxl.close_port_only()


FIGURES = {
    "dxl_cycle_16_ms": lambda quick: _cycle(quick, fast=True),
    "dxl_cycle_16_plain_ms": lambda quick: _cycle(quick, fast=False),
}
