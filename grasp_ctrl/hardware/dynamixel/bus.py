"""A Dynamixel Protocol 2.0 bus on ``dynamixel_sdk`` with bounded retries.

Every transaction is retried up to ``retries`` extra times on communication
errors (timeout, corrupt reply) and then raises ``HardwareError`` naming the
servo. Status-packet error codes (access, data limit, ...) are not retried:
they are answers, not noise. Sync reads use Fast Sync Read (one status packet
for the whole chain) when the SDK and the servos support it, else the plain
Sync Read (one status packet per servo); both are parsed here from the SDK's
packet layer so per-servo error bytes (the alert bit) are kept and a short or
damaged reply is reported instead of crashing the SDK's own parser.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from dynamixel_sdk import COMM_SUCCESS, GroupSyncRead, GroupSyncWrite, PacketHandler

from grasp_ctrl.errors import HardwareError
from grasp_ctrl.hardware.dynamixel.port import ShortTimeoutPortHandler

_STATUS_ERRORS = {
    1: "result_fail",
    2: "instruction_error",
    3: "crc_error",
    4: "data_range_error",
    5: "data_length_error",
    6: "data_limit_error",
    7: "access_error",
}
ALERT_BIT = 0x80


def status_error_name(error: int) -> str:
    return _STATUS_ERRORS.get(error & 0x7F, f"status_error_{error & 0x7F}")


@dataclass
class BusStats:
    transactions: int = 0
    comm_errors: int = 0
    retries: int = 0
    fast_sync_reads: int = 0
    plain_sync_reads: int = 0
    alerts: dict[int, int] = field(default_factory=dict)  # id -> times the alert bit was seen


@dataclass(frozen=True)
class SyncReadResult:
    data: dict[int, bytes]
    errors: dict[int, int]  # status error byte per id (bit 7 = hardware alert)


def serial_ports_found() -> str:
    """The serial ports this machine has, for an error message (e.g. a mistyped --port)."""
    try:
        from serial.tools import list_ports

        ports = sorted(p.device for p in list_ports.comports())
    except Exception:  # noqa: BLE001 - listing is a courtesy, never the error itself
        return "serial ports could not be listed"
    return f"serial ports found: {', '.join(ports)}" if ports else "no serial ports found"


def _open_failure(exc: BaseException) -> str:
    """pyserial's message repeats the port and errno; the errno's text says it once."""
    import os

    errno = getattr(exc, "errno", None)
    if isinstance(errno, int):
        return os.strerror(errno).lower()
    return str(exc)


class DynamixelBus:
    def __init__(
        self,
        port: str,
        baud: int,
        names: dict[int, str],
        packet_timeout_ms: float = 8.0,
        retries: int = 2,
        fast_sync_read: bool = True,
        drain_s: float = 0.0,
    ) -> None:
        if not drain_s >= 0.0:
            raise ValueError(f"drain_s: the adapter's latency timer in seconds, >= 0 (got {drain_s!r})")
        # After a failed transaction a late reply may still be in the USB adapter, which holds a
        # short reply up to its latency timer: wait that long before dropping the input, or it
        # arrives while the next request waits and is taken for its answer.
        self.drain_s = drain_s
        self.port_name = port
        self.baud = baud
        self.names = names
        self.retries = retries
        self.port = ShortTimeoutPortHandler(port, packet_timeout_ms)
        self.ph = PacketHandler(2.0)
        self.stats = BusStats()
        self.alert_seen = False  # a status packet carried the hardware-alert bit (reset by the reader)
        # Fast Sync Read needs SDK >= 3.8 (GroupSyncRead.fastSyncReadTxPacket) and servo firmware support.
        self.fast_sync_read = fast_sync_read and hasattr(GroupSyncRead, "fastSyncReadTxPacket")
        self._readers: dict[tuple[int, int, tuple[int, ...]], GroupSyncRead] = {}

    # ---- port ------------------------------------------------------------------
    def open(self) -> None:
        try:
            ok = self.port.openPort() and self.port.setBaudRate(self.baud)
        except Exception as exc:  # pyserial raises SerialException / OSError
            raise HardwareError(
                f"cannot open Dynamixel port {self.port_name}: {_open_failure(exc)}; {serial_ports_found()}"
            ) from None
        if not ok:
            raise HardwareError(
                f"cannot open Dynamixel port {self.port_name} at {self.baud} baud; {serial_ports_found()}"
            )

    def close(self) -> None:
        if self.port.is_open:
            self.port.closePort()

    def unjam(self) -> None:
        """After an interrupted transaction (Ctrl-C inside the SDK) the port stays 'busy'."""
        self.port.is_using = False
        if self.port.is_open:
            try:
                self.port.clearPort()
            except Exception:
                pass

    def label(self, dxl_id: int) -> str:
        name = self.names.get(dxl_id)
        return f"{name} (id {dxl_id})" if name else f"id {dxl_id}"

    def _comm_failed(self, result: int) -> None:
        self.stats.comm_errors += 1
        self.port.is_using = False
        self._drop_late_replies()

    def _drop_late_replies(self) -> None:
        """Wait out the adapter's latency timer, then drop whatever arrived (``drain_s``)."""
        if self.drain_s > 0.0:
            time.sleep(self.drain_s)
        self.port.clearPort()

    # ---- single-servo transactions ---------------------------------------------------
    def ping(self, dxl_id: int) -> tuple[int | None, str]:
        """(model number, '') or (None, why)."""
        result = -1
        for attempt in range(self.retries + 1):
            self.stats.transactions += 1
            model, result, error = self.ph.ping(self.port, dxl_id)
            if result == COMM_SUCCESS:
                return model, ""
            self._comm_failed(result)
            if attempt < self.retries:
                self.stats.retries += 1
        return None, self.ph.getTxRxResult(result).replace("[TxRxResult] ", "")

    def read(self, dxl_id: int, address: int, size: int, signed: bool = False) -> int:
        result = -1
        for attempt in range(self.retries + 1):
            self.stats.transactions += 1
            data, result, error = self.ph.readTxRx(self.port, dxl_id, address, size)
            if result == COMM_SUCCESS and len(data) == size:
                self._note_alert(dxl_id, error)
                if error & 0x7F:
                    raise HardwareError(
                        f"reading address {address} of {self.label(dxl_id)}: {status_error_name(error)}"
                    )
                return int.from_bytes(bytes(data), "little", signed=signed)
            self._comm_failed(result)
            if attempt < self.retries:
                self.stats.retries += 1
        raise HardwareError(f"no valid reply from {self.label(dxl_id)} reading address {address}: {self._why(result)}")

    def write(self, dxl_id: int, address: int, size: int, value: int) -> None:
        data = list(int(value).to_bytes(size, "little", signed=value < 0))
        result = -1
        for attempt in range(self.retries + 1):
            self.stats.transactions += 1
            result, error = self.ph.writeTxRx(self.port, dxl_id, address, size, data)
            if result == COMM_SUCCESS:
                self._note_alert(dxl_id, error)
                if error & 0x7F:
                    raise HardwareError(
                        f"writing {value} to address {address} of {self.label(dxl_id)}: {status_error_name(error)}"
                    )
                return
            self._comm_failed(result)
            if attempt < self.retries:
                self.stats.retries += 1
        raise HardwareError(f"no valid reply from {self.label(dxl_id)} writing address {address}: {self._why(result)}")

    def reboot(self, dxl_id: int) -> None:
        result = -1
        for _attempt in range(self.retries + 1):
            self.stats.transactions += 1
            result, error = self.ph.reboot(self.port, dxl_id)
            if result == COMM_SUCCESS:
                return
            self._comm_failed(result)
        raise HardwareError(f"no reply from {self.label(dxl_id)} to REBOOT: {self._why(result)}")

    # ---- group transactions ---------------------------------------------------------
    def sync_write(self, address: int, size: int, values: dict[int, int]) -> None:
        """One Sync Write packet (no replies, so nothing to retry but the transmit)."""
        group = GroupSyncWrite(self.port, self.ph, address, size)
        for dxl_id, v in values.items():
            group.addParam(dxl_id, list(int(v).to_bytes(size, "little", signed=v < 0)))
        result = -1
        for _attempt in range(self.retries + 1):
            self.stats.transactions += 1
            result = group.txPacket()
            if result == COMM_SUCCESS:
                return
            self._comm_failed(result)
        raise HardwareError(f"sync write to address {address} failed: {self._why(result)}")

    def sync_read(self, ids: list[int], address: int, size: int) -> SyncReadResult:
        """Read ``size`` bytes at ``address`` from every id in one transaction (with retries)."""
        last_problem = ""
        for attempt in range(self.retries + 1):
            self.stats.transactions += 1
            if self.fast_sync_read:
                res, problem = self._fast_sync_read(ids, address, size)
            else:
                res, problem = self._plain_sync_read(ids, address, size)
            if res is not None:
                for i, e in res.errors.items():
                    self._note_alert(i, e)
                return res
            last_problem = problem
            self.stats.comm_errors += 1
            self.port.is_using = False
            self._drop_late_replies()
            if attempt < self.retries:
                self.stats.retries += 1
        raise HardwareError(f"sync read of address {address} failed after {self.retries + 1} tries: {last_problem}")

    def _group(self, ids: list[int], address: int, size: int) -> GroupSyncRead:
        key = (address, size, tuple(ids))
        group = self._readers.get(key)
        if group is None:
            group = GroupSyncRead(self.port, self.ph, address, size)
            for i in ids:
                group.addParam(i)
            self._readers[key] = group
        return group

    def _fast_sync_read(self, ids: list[int], address: int, size: int) -> tuple[SyncReadResult | None, str]:
        group = self._group(ids, address, size)
        result = group.fastSyncReadTxPacket()
        if result != COMM_SUCCESS:
            return None, self._why(result)
        rx, result = self.ph.rxPacket(self.port, True)
        if result != COMM_SUCCESS:
            return None, f"{self._why(result)} (first silent or damaged servo is at or after {self.label(ids[0])})"
        # The SDK does not remove byte stuffing from fast replies; do it before slicing.
        rx = self.ph.removeStuffing(list(rx))
        length = rx[5] | (rx[6] << 8)
        payload = rx[8 : 7 + length]  # per servo: ERR ID DATA CRC_L CRC_H (last CRC = packet CRC)
        seg = size + 4
        n = len(payload) // seg
        if rx[4] != 0xFE or n == 0:
            return None, "malformed fast sync read reply"
        data: dict[int, bytes] = {}
        errors: dict[int, int] = {}
        for k in range(min(n, len(ids))):
            s = payload[k * seg : (k + 1) * seg]
            if s[1] != ids[k]:
                return None, f"reply out of order: expected {self.label(ids[k])}, got id {s[1]}"
            errors[ids[k]] = s[0]
            data[ids[k]] = bytes(s[2 : 2 + size])
        if n < len(ids):
            return None, f"no reply from {self.label(ids[n])}"
        self.stats.fast_sync_reads += 1
        return SyncReadResult(data, errors), ""

    def _plain_sync_read(self, ids: list[int], address: int, size: int) -> tuple[SyncReadResult | None, str]:
        group = self._group(ids, address, size)
        result = group.txPacket()
        if result != COMM_SUCCESS:
            return None, self._why(result)
        data: dict[int, bytes] = {}
        errors: dict[int, int] = {}
        for i in ids:
            raw, result, error = self.ph.readRx(self.port, i, size)
            if result != COMM_SUCCESS or len(raw) != size:
                return None, f"{self._why(result)} from {self.label(i)}"
            data[i] = bytes(raw)
            errors[i] = error
        self.stats.plain_sync_reads += 1
        return SyncReadResult(data, errors), ""

    def _note_alert(self, dxl_id: int, error: int) -> None:
        if error & ALERT_BIT:
            self.alert_seen = True
            self.stats.alerts[dxl_id] = self.stats.alerts.get(dxl_id, 0) + 1

    def _why(self, result: int) -> str:
        return self.ph.getTxRxResult(result).replace("[TxRxResult] ", "").rstrip("!") or f"result {result}"
