"""Protocol v1 of the tactile serial stream (docs/design.md 5.3): constants, CRC, reference encoder.

Binary frame, little-endian, one frame per fingertip per sample::

    0xAA 0x55 | finger u8 | seq u16 | n u8 (=44) | n x u16 values | crc u16

The CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, no final
xor) over the bytes from ``finger`` through the last value. Text mode, one frame
per line: ``F<finger>,<seq>,<v1>,...,<v44>\\n``.
"""

from __future__ import annotations

import binascii
import struct
from collections.abc import Sequence

import numpy as np

from grasp_ctrl.config.sensor_layout import COUNT_MAX, COUNT_MIN, FRAME_LEN

SYNC = b"\xaa\x55"
N_VALUES = FRAME_LEN  # 44, the only length protocol v1 accepts
HEADER_LEN = len(SYNC) + 1 + 2 + 1  # sync, finger, seq, n
FRAME_BYTES = HEADER_LEN + 2 * N_VALUES + 2  # 96
SEQ_MODULO = 1 << 16
MAX_FINGER = 255
VALUE_MIN = COUNT_MIN
VALUE_MAX = COUNT_MAX  # 12-bit ADC counts
CRC_CHECK_VALUE = 0x29B1  # CRC-16/CCITT-FALSE of b"123456789"
MAX_TEXT_LINE = 512  # longer "lines" are garbage (a valid one is < 256 bytes)

_HEADER = struct.Struct("<2sBHB")
_CRC = struct.Struct("<H")


def crc16_ccitt_false(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE. ``binascii.crc_hqx`` is exactly this CRC (poly 0x1021,
    MSB first, no final xor) given the 0xFFFF start value, and runs in C."""
    return binascii.crc_hqx(data, crc)


def crc16_ccitt_false_bitwise(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """The same CRC written out bit by bit, as firmware would (used to cross-check)."""
    for byte in bytes(data):
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def _check_fields(finger: int, seq: int, values: Sequence[int] | np.ndarray, check_range: bool) -> np.ndarray:
    if not 0 <= finger <= MAX_FINGER:
        raise ValueError(f"finger must be 0..{MAX_FINGER}, got {finger}")
    if not 0 <= seq < SEQ_MODULO:
        raise ValueError(f"seq must be 0..{SEQ_MODULO - 1}, got {seq}")
    v = np.asarray(values)
    if v.shape != (N_VALUES,):
        raise ValueError(f"a frame has {N_VALUES} values, got shape {v.shape}")
    if not np.issubdtype(v.dtype, np.integer):
        if not np.all(np.isfinite(v)) or np.any(v != np.round(v)):
            raise ValueError("frame values must be integer counts")
    v = v.astype(np.int64)
    lo, hi = (VALUE_MIN, VALUE_MAX) if check_range else (0, 0xFFFF)
    if v.min() < lo or v.max() > hi:
        raise ValueError(f"frame values must be {lo}..{hi}, got {v.min()}..{v.max()}")
    return v


def encode_binary(finger: int, seq: int, values: Sequence[int] | np.ndarray, *, check_range: bool = True) -> bytes:
    """The reference encoder: one binary frame (96 bytes).

    ``check_range=False`` allows any u16 value; only tests use it, to build frames
    the decoder must reject for their range.
    """
    v = _check_fields(finger, seq, values, check_range)
    body = _HEADER.pack(SYNC, finger, seq, N_VALUES)[len(SYNC) :] + v.astype("<u2").tobytes()
    return SYNC + body + _CRC.pack(crc16_ccitt_false(body))


def encode_text(finger: int, seq: int, values: Sequence[int] | np.ndarray) -> bytes:
    """One text-mode line, ``F<finger>,<seq>,<v1>,...,<v44>\\n`` (ASCII decimal)."""
    v = _check_fields(finger, seq, values, True)
    return ("F%d,%d," % (finger, seq) + ",".join(str(int(x)) for x in v) + "\n").encode("ascii")


def seq_next(seq: int) -> int:
    return (seq + 1) % SEQ_MODULO
