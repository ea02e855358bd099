"""The emulated Allegro in a process of its own, on one end of a socket pair: the other side of
the PD process (hardware/allegro/pd_process.py) when the dry run runs on the wall clock.

``AllegroCANEmulatorProcess`` starts the child (``AllegroCANEmulator`` with its 3 ms position stream,
emulators/allegro_can.py) and offers its owner the emulator's interface through shared memory
(hardware/allegro/child.py's ``SharedBlock``): the joint angles it reports (``set_positions``,
the world's), the torques and the system state it received (``pwm``, ``torque_nm``,
``system_on``, ``period_ms``), the faults to inject (``silent``, ``set_temperature``, ``status``,
``send_error_frame``) and, with ``log_capacity``, the torque frames with their arrival times
(``torque_log``, ``torque_times``: ``time.monotonic``, one clock for every process on Linux).
Like the PD process it ignores SIGINT and SIGTERM, stops when its owner says so or has gone, and
its owner reaps it (``close``).
"""

from __future__ import annotations

import os
import socket
import time

import numpy as np

from grasp_ctrl.emulators.allegro_can import ROOM_C, AllegroCANEmulator
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.child import Child, Layout, SharedBlock, SocketLink, parent_alive, start_child
from grasp_ctrl.hardware.allegro.protocol import CanFrame, JointMap

STARTUP_S = 30.0  # the child's interpreter and imports on a loaded host
STOP_S = 1.0
_N_PWM = pr.N_FINGERS * pr.JOINTS_PER_FINGER
_LOG_ROW = 6  # arrival time, finger, four PWM values


def emulator_layout(n_joints: int, log_capacity: int) -> Layout:
    floats = {
        "q_seq": 1,
        "q": n_joints,
        "pwm": _N_PWM,
        "system_on": 1,
        "torque_frames": 1,
        "period_ms": 3,
        "silent": 1,
        "temps": pr.N_TEMPERATURE_SENSORS,
        "status": 1,
        "error_req": 1,
        "stop": 1,
        "ready": 1,
        "log_n": 1,
        "log": log_capacity * _LOG_ROW,
    }
    return Layout(floats, {})


# ---- the child -------------------------------------------------------------------------------------
def _shared_emulator(
    link: SocketLink, joints: JointMap, q0: np.ndarray, block: SharedBlock, parent_pid: int
) -> AllegroCANEmulator:
    capacity = len(block.f["log"]) // _LOG_ROW

    class SharedEmulator(AllegroCANEmulator):
        """The emulator, its owner's orders taken between frames and what it received shared."""

        q_seq = -1.0
        error_req = 0.0

        def between_frames(self) -> None:
            b = block
            if b["stop"] or not parent_alive(parent_pid):
                self._stop.set()
            self.silent = bool(b["silent"])
            self.status = int(b["status"])
            self.temperatures_c = [int(c) for c in b.f["temps"]]
            if b["error_req"] != self.error_req:
                self.error_req = b["error_req"]
                self.send_error_frame()

        def send_positions(self) -> None:
            if block["q_seq"] != self.q_seq:
                got = block.read_seq("q_seq", ("q",))
                if got is not None:
                    self.q_seq = got[0]
                    self.set_positions(got[1][0])
            super().send_positions()

        def handle(self, frame: CanFrame) -> None:
            before = self.torque_frames
            super().handle(frame)
            b = block
            b.f["pwm"][:] = self._pwm.ravel()
            b["system_on"] = 1.0 if self.system_on else 0.0
            b.f["period_ms"][:] = self.period_ms
            if self.torque_frames != before:
                b["torque_frames"] = self.torque_frames
                n = int(b["log_n"])
                if n < capacity:
                    finger, pwm = pr.decode_torque(frame)
                    b.f["log"][n * _LOG_ROW : (n + 1) * _LOG_ROW] = (time.monotonic(), finger, *pwm)
                    b["log_n"] = n + 1

    return SharedEmulator(link, joints, q0, stream=True)


def child_main(payload: tuple[JointMap, np.ndarray, int, int, int, int]) -> None:
    joints, q0, block_fd, log_capacity, link_fd, parent_pid = payload
    block = SharedBlock(emulator_layout(len(joints.finger), log_capacity), fd=block_fd)
    link = SocketLink.from_fd(link_fd, "emulated Allegro")
    emu = _shared_emulator(link, joints, q0, block, parent_pid)
    code = 0
    try:
        block["ready"] = 1.0
        emu._run()
    except BaseException:
        code = 1
    finally:
        link.close()
    os._exit(code)


# ---- the owner's side -------------------------------------------------------------------------------
class AllegroCANEmulatorProcess:
    """``AllegroCANEmulator``'s owner interface, the emulator in its own process on ``sock``
    (one end of ``child.socket_pair``; this process closes its copy once the child has it)."""

    def __init__(self, sock: socket.socket, joints: JointMap, q0_rad: np.ndarray, log_capacity: int = 0) -> None:
        self.joints = joints
        self.device_id = joints.device_id
        self._sock = sock
        self._q0 = np.array(q0_rad, dtype=float)
        self.log_capacity = int(log_capacity)
        self.block = SharedBlock(emulator_layout(len(joints.finger), self.log_capacity))
        self.block.f["temps"][:] = ROOM_C
        self.child: Child | None = None

    def start(self) -> None:
        b = self.block
        payload = (self.joints, self._q0, b.fd, self.log_capacity, self._sock.fileno(), os.getpid())
        self.child = start_child(
            f"{__name__}:child_main", payload, [b.fd, self._sock.fileno()], name="the emulated Allegro"
        )
        b.release_fd()
        self._sock.close()
        try:
            if not self.child.wait_ready(b, STARTUP_S):
                raise HardwareError("the emulated Allegro's process did not start")
        except BaseException:
            self.close()
            raise

    # ---- the owner's side of the emulator -------------------------------------------------------
    def set_positions(self, q_rad: np.ndarray) -> None:
        self.block.write_seq("q_seq", {"q": np.asarray(q_rad, dtype=float)})

    @property
    def pwm(self) -> np.ndarray:
        return self.block.f["pwm"].astype(np.int64).reshape(pr.N_FINGERS, pr.JOINTS_PER_FINGER)

    def torque_nm(self) -> np.ndarray:
        return self.joints.torque_nm(self.pwm)

    @property
    def system_on(self) -> bool:
        return bool(self.block["system_on"])

    @property
    def torque_frames(self) -> int:
        return int(self.block["torque_frames"])

    @property
    def period_ms(self) -> tuple[int, int, int]:
        a, b, c = (int(v) for v in self.block.f["period_ms"])
        return a, b, c

    @property
    def silent(self) -> bool:
        return bool(self.block["silent"])

    @silent.setter
    def silent(self, value: bool) -> None:
        self.block["silent"] = 1.0 if value else 0.0

    @property
    def status(self) -> int:
        return int(self.block["status"])

    @status.setter
    def status(self, value: int) -> None:
        self.block["status"] = float(value)

    def set_temperature(self, sensor: int, celsius: int) -> None:
        self.block.f["temps"][sensor] = float(celsius)

    def send_error_frame(self) -> None:
        self.block["error_req"] = self.block["error_req"] + 1.0

    def torque_log(self) -> list[tuple[float, int, tuple[int, int, int, int]]]:
        """(arrival time, finger, PWM values) of each torque frame, in arrival order."""
        n = int(self.block["log_n"])
        rows = self.block.f["log"][: n * _LOG_ROW].reshape(n, _LOG_ROW)
        return [(float(r[0]), int(r[1]), (int(r[2]), int(r[3]), int(r[4]), int(r[5]))) for r in rows]

    def close(self) -> None:
        """Stop the child and reap it."""
        child, self.child = self.child, None
        self.block["stop"] = 1.0
        self.block.release_fd()
        if child is not None:
            child.stop(STOP_S)
        if self._sock.fileno() >= 0:
            self._sock.close()
