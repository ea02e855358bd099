"""An Allegro Hand v4 on python-can's virtual bus: answers as the hand does (hardware/allegro/protocol.py).

It takes system on/off, the report periods and the per-finger torque frames, and answers the remote
requests: hand information (hardware version 4, right hand, its temperature and status bits), the
serial number, each finger's joint positions and the four temperatures. With ``stream`` it reports
the joint positions every position period on the wall clock, as the real hand does after
``SET_PERIOD``; without, it reports them when asked or when its owner calls ``send_positions``
(the emulated hand's lockstep, emulators/allegro_can_world.py). The joints' angles come from its
owner (``set_positions``); the torques it received are ``pwm`` / ``torque_nm``.

Faults to inject from Python: ``silent`` (no frame at all: a hand that went away),
``set_temperature`` (over-temperature), ``status`` bits (the hand's own faults),
``send_error_frame`` (what a controller reports for bus errors or bus-off).

python-can's virtual bus lives inside one process: the emulator is for Python sessions, the tests
and ``run --emulate`` (``AllegroCANEmulator.on_virtual_channel``), not for another program. Across
processes (the PD loop in its own, ``run --emulate --realtime``) it runs in a process of its own
on a socket pair (emulators/allegro_can_process.py).
"""

from __future__ import annotations

import threading
import time

import numpy as np

from grasp_ctrl.hardware.allegro import protocol as pr
from grasp_ctrl.hardware.allegro.bus import CanLink, PythonCanLink, require_python_can
from grasp_ctrl.hardware.allegro.protocol import CanFrame, HandInfo, JointMap, ProtocolError

HARDWARE_VERSION = 4
FIRMWARE_VERSION = 0x0100  # any: the driver prints it
ROOM_C = 35  # the emulated motors' temperature


def virtual_link(channel: str, name: str = "") -> PythonCanLink:
    """A python-can virtual bus on ``channel`` (in-process) as a CanLink."""
    can = require_python_can()
    return PythonCanLink(can.Bus(interface="virtual", channel=channel, receive_own_messages=False), name or channel)


class AllegroCANEmulator:
    def __init__(
        self,
        link: CanLink,
        joints: JointMap,
        q0_rad: np.ndarray,
        *,
        stream: bool = True,
        serial: str = "EMU00001",
        right_hand: bool = True,
    ) -> None:
        self.link = link
        self.joints = joints
        self.stream = stream
        self.serial = serial
        self.right_hand = right_hand
        self.device_id = joints.device_id
        self._lock = threading.Lock()
        self._counts = joints.counts(q0_rad)
        self._pwm = np.zeros((pr.N_FINGERS, pr.JOINTS_PER_FINGER), dtype=np.int64)
        self.system_on = False
        self.period_ms = (0, 0, 0)
        self.temperatures_c = [ROOM_C] * pr.N_TEMPERATURE_SENSORS
        self.status = 0  # besides the servo-on bit
        self.silent = False
        self.torque_frames = 0
        self.torque_log: list[tuple[int, tuple[int, int, int, int]]] = []  # (finger, pwm), in arrival order
        self.torque_times: list[float] = []  # when each logged frame arrived (time.perf_counter)
        self.keep_log = False
        self.bad_frames = 0
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    @classmethod
    def on_virtual_channel(cls, channel: str, joints: JointMap, q0_rad: np.ndarray, **kw: object) -> AllegroCANEmulator:
        return cls(virtual_link(channel, f"emulated Allegro on {channel}"), joints, q0_rad, **kw)  # type: ignore[arg-type]

    # ---- the owner's side --------------------------------------------------------------------------
    def set_positions(self, q_rad: np.ndarray) -> None:
        """The joints' angles (the hand file's order and convention) the hand reports from now on."""
        counts = self.joints.counts(q_rad)
        with self._lock:
            self._counts = counts

    @property
    def pwm(self) -> np.ndarray:
        """(4, 4) the PWM values last received (finger, joint)."""
        with self._lock:
            return self._pwm.copy()

    def torque_nm(self) -> np.ndarray:
        """The torques last received (N m, the hand file's joints)."""
        return self.joints.torque_nm(self.pwm)

    def set_temperature(self, sensor: int, celsius: int) -> None:
        self.temperatures_c[sensor] = int(celsius)

    def send_positions(self) -> None:
        """Report every finger's joint positions now."""
        for f in range(pr.N_FINGERS):
            self._reply(pr.finger_pose(f, self._finger_counts(f), self.device_id))

    def send_error_frame(self) -> None:
        """An error frame on the bus (a controller's report of bus errors; bus-off)."""
        self.link.send(CanFrame(0x040, bytes(8), is_error=True))

    # ---- the hand's side ---------------------------------------------------------------------------
    def handle(self, frame: CanFrame) -> None:
        """One frame from the host."""
        if frame.is_error or frame.is_extended or frame.device_id != self.device_id:
            return
        cmd = frame.command
        if frame.is_remote:
            self._answer(cmd)
            return
        try:
            if pr.CMD_SET_TORQUE <= cmd < pr.CMD_SET_TORQUE + pr.N_FINGERS:
                finger, pwm = pr.decode_torque(frame)
                with self._lock:
                    self._pwm[finger] = pwm
                    self.torque_frames += 1
                    if self.keep_log:
                        self.torque_log.append((finger, pwm))
                        self.torque_times.append(time.perf_counter())
            elif cmd == pr.CMD_SET_PERIOD:
                self.period_ms = pr.decode_period(frame)
            elif cmd == pr.CMD_SYSTEM_ON:
                self.system_on = True
            elif cmd == pr.CMD_SYSTEM_OFF:
                self.system_on = False
                with self._lock:
                    self._pwm[:] = 0
        except ProtocolError:
            self.bad_frames += 1

    def _answer(self, cmd: int) -> None:
        dev = self.device_id
        if pr.RTR_FINGER_POSE <= cmd < pr.RTR_FINGER_POSE + pr.N_FINGERS:
            f = cmd - pr.RTR_FINGER_POSE
            self._reply(pr.finger_pose(f, self._finger_counts(f), dev))
        elif cmd == pr.RTR_HAND_INFO:
            info = HandInfo(
                HARDWARE_VERSION,
                FIRMWARE_VERSION,
                self.right_hand,
                max(self.temperatures_c),
                (pr.STATUS_SERVO_ON if self.system_on else 0) | self.status,
            )
            self._reply(pr.hand_info(info, dev))
        elif cmd == pr.RTR_SERIAL:
            self._reply(pr.serial_number(self.serial, dev))
        elif pr.RTR_TEMPERATURE <= cmd < pr.RTR_TEMPERATURE + pr.N_TEMPERATURE_SENSORS:
            s = cmd - pr.RTR_TEMPERATURE
            self._reply(pr.temperature(s, self.temperatures_c[s], dev))

    def _finger_counts(self, finger: int) -> list[int]:
        with self._lock:
            return [int(c) for c in self._counts[finger]]

    def _reply(self, frame: CanFrame) -> None:
        if not self.silent:
            self.link.send(frame)

    # ---- its thread ----------------------------------------------------------------------------------
    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="allegro-can-emulator", daemon=True)
        self._thread.start()

    def between_frames(self) -> None:
        """Called before each wait for a frame (the emulated hand's process takes its owner's
        orders here, emulators/allegro_can_process.py)."""

    def _run(self) -> None:
        next_report = time.perf_counter()
        while not self._stop.is_set():
            self.between_frames()
            period_s = self.period_ms[0] / 1000.0
            streaming = self.stream and period_s > 0
            wait = max(0.0, next_report - time.perf_counter()) if streaming else 0.005
            try:
                frame = self.link.recv(min(wait, 0.005))
            except Exception:
                if self._stop.is_set():
                    return
                raise
            if frame is not None:
                self.handle(frame)
            if streaming and time.perf_counter() >= next_report:
                self.send_positions()
                next_report = max(next_report + period_s, time.perf_counter() - period_s)

    def stop(self) -> None:
        thread, self._thread = self._thread, None
        if thread is not None:
            self._stop.set()
            thread.join(1.0)

    def close(self) -> None:
        self.stop()
        self.link.close()
