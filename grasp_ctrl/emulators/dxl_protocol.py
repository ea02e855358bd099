"""Dynamixel Protocol 2.0 framing, written from the protocol description.

Packet: FF FF FD 00 | ID | LEN_L LEN_H | INST | params... | CRC_L CRC_H, where
LEN counts INST + params + CRC, the CRC is CRC-16 (poly 0x8005, init 0, no
reflection) over everything before it, and the byte sequence FF FF FD inside
INST/params is stuffed as FF FF FD FD. Kept independent of ``dynamixel_sdk``
so the emulator checks the SDK rather than mirroring it.
"""

from __future__ import annotations

from dataclasses import dataclass

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
INST_STATUS = 0x55

INST_PING = 0x01
INST_READ = 0x02
INST_WRITE = 0x03
INST_REBOOT = 0x08
INST_SYNC_READ = 0x82
INST_SYNC_WRITE = 0x83
INST_FAST_SYNC_READ = 0x8A

# Status "error" byte: bit 7 = alert (hardware error status is non-zero),
# bits 0-6 = the instruction's result code.
ERR_RESULT_FAIL = 0x01
ERR_INSTRUCTION = 0x02
ERR_CRC = 0x03
ERR_DATA_RANGE = 0x04
ERR_DATA_LENGTH = 0x05
ERR_DATA_LIMIT = 0x06
ERR_ACCESS = 0x07
ERR_ALERT = 0x80


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return table


_CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray, crc: int = 0) -> int:
    for b in data:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ b) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert 0xFD after every FF FF FD inside ``body`` (INST + params).

    The two bytes before the body (LEN_H and, before it, LEN_L) cannot start a
    pattern with body bytes in practice, but count them like the protocol does."""
    out = bytearray()
    for b in body:
        out.append(b)
        if b == 0xFD and len(out) >= 3 and out[-2] == 0xFF and out[-3] == 0xFF:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    out = bytearray()
    i = 0
    while i < len(body):
        b = body[i]
        out.append(b)
        if (
            b == 0xFD
            and len(out) >= 3
            and out[-2] == 0xFF
            and out[-3] == 0xFF
            and i + 1 < len(body)
            and body[i + 1] == 0xFD
        ):
            i += 1  # skip the stuffed byte
        i += 1
    return bytes(out)


def build_packet(dxl_id: int, inst: int, params: bytes = b"") -> bytes:
    body = stuff(bytes([inst]) + bytes(params))
    length = len(body) + 2
    head = HEADER + bytes([dxl_id, length & 0xFF, length >> 8])
    pkt = head + body
    crc = crc16(pkt)
    return pkt + bytes([crc & 0xFF, crc >> 8])


def build_status(dxl_id: int, error: int, params: bytes = b"") -> bytes:
    return build_packet(dxl_id, INST_STATUS, bytes([error]) + bytes(params))


@dataclass(frozen=True)
class Packet:
    dxl_id: int
    inst: int
    params: bytes  # unstuffed


class PacketParser:
    """Incremental parser: feed bytes, collect whole packets; counts CRC failures.

    A packet with a bad CRC is reported as ``(None, id)`` so a servo can answer
    with a CRC error status like the real firmware."""

    def __init__(self) -> None:
        self.buf = bytearray()
        self.crc_errors = 0

    def feed(self, data: bytes) -> list[tuple[Packet | None, int]]:
        self.buf += data
        out: list[tuple[Packet | None, int]] = []
        while True:
            start = self.buf.find(HEADER)
            if start < 0:
                # keep a possible partial header at the end
                del self.buf[: max(0, len(self.buf) - 3)]
                return out
            del self.buf[:start]
            if len(self.buf) < 7:
                return out
            length = self.buf[5] | (self.buf[6] << 8)
            total = 7 + length
            if length < 3 or length > 1024:
                del self.buf[:1]
                continue
            if len(self.buf) < total:
                return out
            pkt = bytes(self.buf[:total])
            del self.buf[:total]
            dxl_id = pkt[4]
            if crc16(pkt[:-2]) != (pkt[-2] | (pkt[-1] << 8)):
                self.crc_errors += 1
                out.append((None, dxl_id))
                continue
            body = unstuff(pkt[7:-2])
            out.append((Packet(dxl_id, body[0], body[1:]), dxl_id))
