"""Property tests of the protocol v1 decoders: untrusted byte streams in, frames and counters out."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from grasp_ctrl.tactile_link.decoder import BinaryDecoder, TextDecoder
from grasp_ctrl.tactile_link.protocol import FRAME_BYTES, SEQ_MODULO, SYNC, encode_binary, encode_text

values_st = st.lists(st.integers(0, 4095), min_size=44, max_size=44)
frame_st = st.tuples(st.integers(0, 255), st.integers(0, SEQ_MODULO - 1), values_st)


@dataclass
class Seg:
    kind: str  # intact | flip | trunc | garbage | range
    data: bytes
    frame: tuple | None = None
    flip_byte: int = -1


@st.composite
def binary_segment(draw) -> Seg:
    kind = draw(st.sampled_from(["intact", "intact", "flip", "trunc", "garbage", "range"]))
    if kind == "garbage":
        return Seg(kind, draw(st.binary(min_size=0, max_size=150)))
    finger, seq, values = draw(frame_st)
    if kind == "range":
        bad = list(values)
        bad[draw(st.integers(0, 43))] = draw(st.integers(4096, 0xFFFF))
        return Seg(kind, encode_binary(finger, seq, bad, check_range=False))
    raw = encode_binary(finger, seq, values)
    if kind == "intact":
        return Seg(kind, raw, (finger, seq, tuple(values)))
    if kind == "flip":
        bit = draw(st.integers(0, 8 * FRAME_BYTES - 1))
        data = bytearray(raw)
        data[bit // 8] ^= 1 << (bit % 8)
        return Seg(kind, bytes(data), flip_byte=bit // 8)
    return Seg(kind, raw[: draw(st.integers(6, FRAME_BYTES - 1))])


def sync_positions(stream: bytes) -> list[int]:
    out, i = [], stream.find(SYNC)
    while i >= 0:
        out.append(i)
        i = stream.find(SYNC, i + 1)
    return out


def feed_in_chunks(dec, stream: bytes, cuts: list[int]):
    frames = []
    prev = 0
    for c in sorted(set(min(c, len(stream)) for c in cuts)) + [len(stream)]:
        frames += dec.feed(stream[prev:c])
        prev = c
    return frames


def expected_seq_counters(frames: list[tuple]) -> tuple[int, int]:
    gaps = lost = 0
    last: dict[int, int] = {}
    for finger, seq, _ in frames:
        if finger in last and seq != (last[finger] + 1) % SEQ_MODULO:
            gaps += 1
            jump = (seq - last[finger]) % SEQ_MODULO
            if 0 < jump < SEQ_MODULO // 2:
                lost += jump - 1
        last[finger] = seq
    return gaps, lost


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(segs=st.lists(binary_segment(), max_size=25), last=frame_st, cuts=st.lists(st.integers(0, 4000), max_size=8))
def test_binary_counters_are_exact(segs: list[Seg], last: tuple, cuts: list[int]) -> None:
    segs = segs + [Seg("intact", encode_binary(last[0], last[1], last[2]), (last[0], last[1], tuple(last[2])))]
    stream = b"".join(s.data for s in segs)
    # Keep the bookkeeping exact: the only sync patterns are real frame starts.
    starts, pos = [], 0
    for s in segs:
        if s.kind in ("intact", "range", "trunc") or (s.kind == "flip" and s.flip_byte > 1):
            starts.append(pos)
        pos += len(s.data)
    assume(sync_positions(stream) == starts)

    dec = BinaryDecoder()
    got = [(f.finger, f.seq, tuple(int(v) for v in f.values)) for f in feed_in_chunks(dec, stream, cuts)]

    intact = [s.frame for s in segs if s.kind == "intact"]
    assert got == intact
    bad = [s for s in segs if s.kind in ("flip", "trunc") or (s.kind == "garbage" and s.data)]
    runs, in_bad = 0, False
    for s in segs:
        if s in bad:
            runs += not in_bad
            in_bad = True
        elif s.kind in ("intact", "range"):
            in_bad = False
    st_ = dec.stats
    assert st_.frames == len(intact)
    assert st_.crc_errors == sum(
        1 for s in segs if s.kind == "trunc" or (s.kind == "flip" and s.flip_byte not in (0, 1, 5))
    )
    assert st_.length_errors == sum(1 for s in segs if s.kind == "flip" and s.flip_byte == 5)
    assert st_.range_errors == sum(1 for s in segs if s.kind == "range")
    assert st_.resyncs == runs
    assert st_.bytes_discarded == sum(len(s.data) for s in bad)
    assert (st_.seq_gaps, st_.seq_lost) == expected_seq_counters(intact)
    assert dec.pending_bytes == 0


@settings(max_examples=300, deadline=None)
@given(
    parts=st.lists(st.one_of(st.binary(max_size=200), frame_st), max_size=20),
    cuts=st.lists(st.integers(0, 5000), max_size=10),
)
def test_binary_arbitrary_bytes_never_lose_intact_frames(parts: list, cuts: list[int]) -> None:
    stream = b""
    embedded = []
    for p in parts:
        if isinstance(p, bytes):
            stream += p
        else:
            stream += encode_binary(*p)
            embedded.append((p[0], p[1], tuple(p[2])))
    dec = BinaryDecoder()
    got = [(f.finger, f.seq, tuple(int(v) for v in f.values)) for f in feed_in_chunks(dec, stream, cuts)]
    # Every embedded frame comes out, in order (garbage could in principle hold extra valid frames).
    it = iter(got)
    assert all(any(g == e for g in it) for e in embedded)
    s = dec.stats
    # Byte conservation: each byte was delivered or rejected in an intact frame, discarded, or is pending.
    assert FRAME_BYTES * (s.frames + s.range_errors) + s.bytes_discarded + dec.pending_bytes == len(stream)
    assert s.frames == len(got)
    assert all(f.values.shape == (44,) and f.values.min() >= 0 and f.values.max() <= 4095 for f in dec.feed(b""))


def test_binary_decoder_rejects_wrong_length_and_resyncs() -> None:
    good = encode_binary(2, 7, np.full(44, 1000))
    bad_n = bytearray(good)
    bad_n[5] = 43
    dec = BinaryDecoder()
    frames = dec.feed(bytes(bad_n) + good)
    assert [(f.finger, f.seq) for f in frames] == [(2, 7)]
    assert dec.stats.length_errors == 1 and dec.stats.resyncs == 1
    assert dec.stats.bytes_discarded == FRAME_BYTES


def test_seq_gap_counts_lost_frames_and_wraps() -> None:
    dec = BinaryDecoder()
    v = np.zeros(44)
    dec.feed(encode_binary(0, 65534, v) + encode_binary(0, 65535, v) + encode_binary(0, 0, v))
    assert dec.stats.seq_gaps == 0
    dec.feed(encode_binary(0, 5, v) + encode_binary(1, 9, v))
    assert dec.stats.seq_gaps == 1 and dec.stats.seq_lost == 4


# ---------------------------------------------------------------- text mode

garbage_line_st = st.binary(min_size=1, max_size=100).filter(
    lambda b: b"F" not in b and b"\n" not in b and b"\r" not in b and not b.startswith(b"#")
)  # "#": a comment line


@st.composite
def text_segments(draw) -> list[tuple[str, bytes, tuple | None]]:
    kind = draw(st.sampled_from(["intact", "intact", "xchar", "trunc", "garbage", "range"]))
    finger, seq, values = draw(frame_st)
    line = encode_text(finger, seq, values)
    if kind == "intact":
        return [("intact", line, (finger, seq, tuple(values)))]
    if kind == "xchar":
        i = draw(st.integers(0, len(line) - 2))
        return [("bad", line[:i] + b"x" + line[i + 1 :], None)]
    if kind == "trunc":
        # A line that lost its end runs into the next line; the next line must survive.
        cut = draw(st.integers(1, len(line) - 1))
        f2, s2, v2 = draw(frame_st)
        return [("bad", line[:cut], None), ("intact", encode_text(f2, s2, v2), (f2, s2, tuple(v2)))]
    if kind == "range":
        return [("range", _range_line(finger, seq, values), None)]
    return [("bad", draw(garbage_line_st) + b"\n", None)]


def _range_line(finger: int, seq: int, values: list[int]) -> bytes:
    return ("F%d,%d," % (finger, seq) + ",".join(str(v) for v in values[:-1]) + ",4096\n").encode()


@settings(max_examples=200, deadline=None)
@given(groups=st.lists(text_segments(), max_size=20), cuts=st.lists(st.integers(0, 8000), max_size=8))
def test_text_counters_are_exact(groups: list, cuts: list[int]) -> None:
    segs = [s for g in groups for s in g]
    stream = b"".join(s[1] for s in segs)
    dec = TextDecoder()
    got = [(f.finger, f.seq, tuple(int(v) for v in f.values)) for f in feed_in_chunks(dec, stream, cuts)]
    intact = [s[2] for s in segs if s[0] == "intact"]
    assert got == intact
    n_bad = sum(1 for s in segs if s[0] == "bad")
    s = dec.stats
    assert s.format_errors + s.length_errors == n_bad
    assert s.range_errors == sum(1 for x in segs if x[0] == "range")
    assert s.bytes_discarded == sum(len(x[1]) for x in segs if x[0] == "bad")
    runs, in_bad = 0, False
    for kind, _, _ in segs:
        if kind == "bad":
            runs += not in_bad
            in_bad = True
        else:
            in_bad = False
    assert s.resyncs == runs
    assert (s.seq_gaps, s.seq_lost) == expected_seq_counters(intact)


@settings(max_examples=200, deadline=None)
@given(
    parts=st.lists(st.one_of(st.binary(max_size=120), frame_st), max_size=15),
    cuts=st.lists(st.integers(0, 6000), max_size=8),
)
def test_text_arbitrary_bytes_never_crash(parts: list, cuts: list[int]) -> None:
    stream = b""
    embedded = []
    for p in parts:
        if isinstance(p, bytes):
            # Whatever precedes a frame, a newline before it keeps it separable.
            stream += p + b"\n"
        else:
            stream += encode_text(*p)
            embedded.append((p[0], p[1], tuple(p[2])))
    dec = TextDecoder()
    got = [(f.finger, f.seq, tuple(int(v) for v in f.values)) for f in feed_in_chunks(dec, stream, cuts)]
    it = iter(got)
    assert all(any(g == e for g in it) for e in embedded)
    assert dec.stats.frames == len(got)


def test_text_decoder_accepts_crlf_and_rejects_overlong_lines() -> None:
    v = list(range(44))
    dec = TextDecoder()
    frames = dec.feed(encode_text(1, 2, v).replace(b"\n", b"\r\n"))
    assert [(f.finger, f.seq) for f in frames] == [(1, 2)]
    frames = dec.feed(b"9" * 600)
    frames += dec.feed(b"9" * 600 + b"\n" + encode_text(1, 3, v))
    assert [(f.finger, f.seq) for f in frames] == [(1, 3)]
    assert dec.stats.length_errors == 1 and dec.stats.bytes_discarded == 1201 and dec.stats.resyncs == 1


def test_text_decoder_skips_a_bridges_comment_lines() -> None:
    """'#' lines (the reference firmware's start-up report) are no frames and no errors,
    even when they hold an 'F'."""
    v = list(range(44))
    dec = TextDecoder()
    report = b"# biotac_bridge 1.0 F0 serial BTxxx firmware 3.1\r\n# F3 no answer\n"
    frames = dec.feed(report + encode_text(0, 7, v))
    assert [(f.finger, f.seq) for f in frames] == [(0, 7)]
    assert dec.stats.format_errors == 0 and dec.stats.length_errors == 0 and dec.stats.bytes_discarded == 0
