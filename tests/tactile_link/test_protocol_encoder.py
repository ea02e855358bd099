"""The reference encoder and the CRC of protocol v1 (docs/tactile_protocol.md)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.tactile_link.decoder import BinaryDecoder, TextDecoder
from grasp_ctrl.tactile_link.protocol import (
    CRC_CHECK_VALUE,
    FRAME_BYTES,
    crc16_ccitt_false,
    crc16_ccitt_false_bitwise,
    encode_binary,
    encode_text,
)

DOC = Path(__file__).resolve().parents[2] / "docs" / "tactile_protocol.md"
EXAMPLE_VALUES = list(range(3000, 3019)) + [2450] + [2048] * 22 + [2700, 2040]
frames = st.tuples(st.integers(0, 255), st.integers(0, 65535), st.lists(st.integers(0, 4095), min_size=44, max_size=44))


def test_crc_check_value() -> None:
    assert CRC_CHECK_VALUE == 0x29B1
    assert crc16_ccitt_false(b"123456789") == 0x29B1
    assert crc16_ccitt_false_bitwise(b"123456789") == 0x29B1


@given(st.binary(max_size=300))
def test_fast_crc_equals_the_bitwise_definition(data: bytes) -> None:
    assert crc16_ccitt_false(data) == crc16_ccitt_false_bitwise(data)


def test_frame_layout_matches_the_spec() -> None:
    f = encode_binary(2, 259, EXAMPLE_VALUES)
    assert len(f) == FRAME_BYTES == 96
    assert f[:6] == bytes([0xAA, 0x55, 0x02, 0x03, 0x01, 44])
    assert f[6:8] == (3000).to_bytes(2, "little")
    assert f[6 + 2 * 19 : 8 + 2 * 19] == (2450).to_bytes(2, "little")  # pdc after e19
    assert int.from_bytes(f[94:96], "little") == crc16_ccitt_false_bitwise(f[2:94])


def test_worked_example_in_the_docs_is_what_the_encoder_sends() -> None:
    text = DOC.read_text()
    block = text.split("### Worked example", 1)[1].split("```", 2)[1]
    expected = bytearray()
    for line in block.strip().splitlines():
        hexpart = line[:40].strip()
        m = re.fullmatch(r"00 08 \(x 22\)", hexpart)
        expected += bytes([0x00, 0x08] * 22) if m else bytes.fromhex(hexpart)
    assert bytes(expected) == encode_binary(2, 259, EXAMPLE_VALUES)
    assert "0xE627" in text and crc16_ccitt_false(bytes([2, 3, 1, 44])) == 0xE627


def test_text_line_format() -> None:
    line = encode_text(2, 259, EXAMPLE_VALUES)
    assert line.startswith(b"F2,259,3000,3001,") and line.endswith(b",2700,2040\n")
    assert line.count(b",") == 45


@pytest.mark.parametrize(
    "finger, seq, values",
    [
        (256, 0, [0] * 44),
        (-1, 0, [0] * 44),
        (0, 65536, [0] * 44),
        (0, 0, [0] * 43),
        (0, 0, [4096] + [0] * 43),
        (0, 0, [-1] + [0] * 43),
        (0, 0, [0.5] + [0] * 43),
    ],
)
def test_encoder_refuses_what_the_protocol_cannot_carry(finger, seq, values) -> None:
    with pytest.raises(ValueError):
        encode_binary(finger, seq, values)
    with pytest.raises(ValueError):
        encode_text(finger, seq, values)


@settings(max_examples=200, deadline=None)
@given(frames)
def test_round_trip_both_modes(frame) -> None:
    finger, seq, values = frame
    for enc, dec in ((encode_binary, BinaryDecoder()), (encode_text, TextDecoder())):
        (out,) = dec.feed(enc(finger, seq, values))
        assert (out.finger, out.seq) == (finger, seq)
        np.testing.assert_array_equal(out.values, values)


@settings(max_examples=300, deadline=None)
@given(frames, st.lists(st.integers(0, 8 * FRAME_BYTES - 1), min_size=1, max_size=3, unique=True))
def test_one_to_three_bit_flips_are_always_caught(frame, bits) -> None:
    data = bytearray(encode_binary(*frame))
    for b in bits:
        data[b // 8] ^= 1 << (b % 8)
    dec = BinaryDecoder()
    assert dec.feed(bytes(data)) == []
