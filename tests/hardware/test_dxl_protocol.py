"""Protocol 2.0 framing of the emulator, checked against published packets and the SDK."""

from __future__ import annotations

from dynamixel_sdk import PacketHandler
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.emulators import dxl_protocol as p


def test_crc_matches_the_published_ping_packet() -> None:
    # PING to id 1 from the Protocol 2.0 documentation: FF FF FD 00 01 03 00 01 19 4E
    assert p.build_packet(1, p.INST_PING) == bytes.fromhex("FFFFFD0001030001194E")


@given(st.binary(max_size=64))
def test_crc_agrees_with_the_sdk(data: bytes) -> None:
    assert p.crc16(data) == PacketHandler(2.0).updateCRC(0, list(data), len(data))


@given(st.lists(st.sampled_from([0x00, 0xFD, 0xFF, 0x55]), max_size=40))
def test_stuffing_round_trip_and_no_header_left(body: list[int]) -> None:
    raw = bytes(body)
    stuffed = p.stuff(raw)
    assert p.unstuff(stuffed) == raw
    # after stuffing, FF FF FD is always followed by FD
    for i in range(len(stuffed) - 2):
        if stuffed[i : i + 3] == b"\xff\xff\xfd":
            assert i + 3 < len(stuffed) and stuffed[i + 3] == 0xFD


@settings(max_examples=50)
@given(st.integers(0, 252), st.binary(max_size=30), st.integers(0, 8))
def test_parser_recovers_packets_from_noise(dxl_id: int, params: bytes, noise_len: int) -> None:
    pkt = p.build_packet(dxl_id, p.INST_WRITE, params)
    parser = p.PacketParser()
    got = parser.feed(b"\x00" * noise_len + pkt[:5]) + parser.feed(pkt[5:])
    assert len(got) == 1 and got[0][0] is not None
    assert got[0][0].params == params and got[0][0].dxl_id == dxl_id


def test_parser_reports_crc_errors_with_the_id() -> None:
    pkt = bytearray(p.build_packet(7, p.INST_PING))
    pkt[-1] ^= 0xFF
    parser = p.PacketParser()
    assert parser.feed(bytes(pkt)) == [(None, 7)]
    assert parser.crc_errors == 1
