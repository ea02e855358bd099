"""Incremental decoders for protocol v1 (binary and text mode).

Bytes arrive in arbitrary chunks; ``feed`` returns the complete valid frames and
keeps any partial frame for the next call. After any bad frame the decoder
advances by ONE byte and searches for the next sync pattern, so a corrupted
frame can never swallow the valid frame that follows it (a false sync found
inside garbage only costs a CRC check).

Counters (``DecoderStats``), all cumulative:

- ``frames``: valid frames delivered.
- ``crc_errors``: complete candidate frames whose CRC does not match.
- ``length_errors``: a binary header with n != 44, or a text line without 46 fields
  (including the remains of a line that lost its newline: text mode also restarts
  at any ``F``, which only ever starts a frame).
- ``range_errors``: a frame that is intact (CRC good / line well formed) but has a
  value outside 0..4095 or an out-of-range finger/seq (text); it is dropped.
- ``format_errors``: a text line that is not ``F<int>,<int>,...`` (binary: never).
- ``resyncs``: times the decoder lost sync, i.e. started discarding bytes while it
  was in sync. It is in sync at the start and after every intact frame (delivered
  or range-rejected), so a run of garbage and bad frames counts once.
- ``bytes_discarded``: bytes skipped while searching for the next frame.
- ``seq_gaps``: per fingertip, a frame whose seq is not the previous seq + 1 (mod 65536).
- ``seq_lost``: frames missing inside forward gaps (sum of jump - 1 for jumps < 32768).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from grasp_ctrl.tactile_link.protocol import (
    FRAME_BYTES,
    HEADER_LEN,
    MAX_FINGER,
    MAX_TEXT_LINE,
    N_VALUES,
    SEQ_MODULO,
    SYNC,
    VALUE_MAX,
    VALUE_MIN,
    crc16_ccitt_false,
)

_SYNC0 = SYNC[0]


@dataclass(frozen=True)
class DecodedFrame:
    finger: int
    seq: int
    values: np.ndarray  # (44,) int32 raw counts, BioTac order


@dataclass
class DecoderStats:
    frames: int = 0
    crc_errors: int = 0
    length_errors: int = 0
    range_errors: int = 0
    format_errors: int = 0
    resyncs: int = 0
    bytes_discarded: int = 0
    seq_gaps: int = 0
    seq_lost: int = 0

    def as_dict(self) -> dict[str, int]:
        return asdict(self)


@dataclass
class _DecoderState:
    stats: DecoderStats = field(default_factory=DecoderStats)
    in_sync: bool = True
    last_seq: dict[int, int] = field(default_factory=dict)


class _DecoderBase:
    def __init__(self) -> None:
        self._buf = bytearray()
        self._state = _DecoderState()

    @property
    def stats(self) -> DecoderStats:
        return self._state.stats

    @property
    def pending_bytes(self) -> int:
        """Bytes held back as a possibly incomplete frame."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget buffered bytes and sequence history (e.g. after a reconnect); keep the counters."""
        self._buf.clear()
        self._state.in_sync = True
        self._state.last_seq.clear()

    def _discard(self, n: int) -> None:
        if n <= 0:
            return
        st = self._state
        if st.in_sync:
            st.stats.resyncs += 1
            st.in_sync = False
        st.stats.bytes_discarded += n

    def _accept(self, finger: int, seq: int, values: np.ndarray) -> DecodedFrame:
        st = self._state
        last = st.last_seq.get(finger)
        if last is not None and seq != (last + 1) % SEQ_MODULO:
            st.stats.seq_gaps += 1
            jump = (seq - last) % SEQ_MODULO
            if 0 < jump < SEQ_MODULO // 2:
                st.stats.seq_lost += jump - 1
        st.last_seq[finger] = seq
        st.stats.frames += 1
        return DecodedFrame(finger, seq, values)


class BinaryDecoder(_DecoderBase):
    """Binary mode: ``0xAA 0x55 | finger | seq | n | values | crc`` frames."""

    mode = "binary"

    def feed(self, data: bytes | bytearray | memoryview) -> list[DecodedFrame]:
        buf = self._buf
        buf += data
        st = self._state
        out: list[DecodedFrame] = []
        pos = 0
        end = len(buf)
        while True:
            i = buf.find(SYNC, pos)
            if i < 0:
                # Nothing usable; keep a trailing 0xAA, it may be the first sync byte.
                keep_from = end - 1 if end > pos and buf[end - 1] == _SYNC0 else end
                self._discard(keep_from - pos)
                pos = keep_from
                break
            self._discard(i - pos)
            pos = i
            if end - pos < HEADER_LEN:
                break
            if buf[pos + 5] != N_VALUES:
                st.stats.length_errors += 1
                self._discard(1)
                pos += 1
                continue
            if end - pos < FRAME_BYTES:
                break
            body = memoryview(buf)[pos + 2 : pos + FRAME_BYTES - 2]
            crc_rx = buf[pos + FRAME_BYTES - 2] | (buf[pos + FRAME_BYTES - 1] << 8)
            if crc16_ccitt_false(body) != crc_rx:
                body.release()
                st.stats.crc_errors += 1
                self._discard(1)
                pos += 1
                continue
            finger = body[0]
            seq = body[1] | (body[2] << 8)
            values = np.frombuffer(body[4:], dtype="<u2").astype(np.int32)
            body.release()
            pos += FRAME_BYTES
            st.in_sync = True  # the CRC vouches for the framing, even if a value is bad
            if values.max() > VALUE_MAX:
                st.stats.range_errors += 1
                continue
            out.append(self._accept(finger, seq, values))
        del buf[:pos]
        return out


class TextDecoder(_DecoderBase):
    """Text mode: one ``F<finger>,<seq>,<v1>,...,<v44>`` line per frame (``\\n`` or ``\\r\\n``)."""

    mode = "text"

    def __init__(self) -> None:
        super().__init__()
        self._skip_line = False  # inside an over-long line: drop up to the next newline

    def feed(self, data: bytes | bytearray | memoryview) -> list[DecodedFrame]:
        buf = self._buf
        buf += data
        out: list[DecodedFrame] = []
        start = 0
        while True:
            nl = buf.find(b"\n", start)
            if nl < 0:
                if len(buf) - start > MAX_TEXT_LINE:
                    if not self._skip_line:
                        self.stats.length_errors += 1
                    self._discard(len(buf) - start)
                    start = len(buf)
                    self._skip_line = True
                break
            line = bytes(buf[start:nl])
            consumed = nl + 1 - start
            start = nl + 1
            if self._skip_line:
                self._skip_line = False
                self._discard(consumed)
                continue
            if line.endswith(b"\r"):
                line = line[:-1]
            if not line or line.startswith(b"#"):
                continue  # blank lines are harmless; '#' lines are a bridge's own notes (start-up report)
            k = line.rfind(b"F")
            if k > 0:
                # 'F' only starts a frame: the text before it is a frame that lost its line end.
                self.stats.length_errors += 1
                self._discard(k)
                line = line[k:]
                consumed -= k
            frame, intact = self._parse(line)
            if frame is not None:
                out.append(frame)
            elif not intact:
                self._discard(consumed)
        del buf[:start]
        return out

    def _parse(self, line: bytes) -> tuple[DecodedFrame | None, bool]:
        """-> (frame or None, whether the line was well formed)."""
        stats = self.stats
        if len(line) > MAX_TEXT_LINE:
            stats.length_errors += 1
            return None, False
        if not line.startswith(b"F"):
            stats.format_errors += 1
            return None, False
        fields = line[1:].split(b",")
        # isdigit on bytes is ASCII-only; int() alone would also accept "+1", " 1" and "1_0".
        if not all(f.isdigit() and len(f) <= 6 for f in fields):
            stats.format_errors += 1
            return None, False
        if len(fields) != 2 + N_VALUES:
            stats.length_errors += 1
            return None, False
        finger, seq = int(fields[0]), int(fields[1])
        values = np.array([int(f) for f in fields[2:]], dtype=np.int32)
        self._state.in_sync = True  # a well-formed line: the framing is fine
        if finger > MAX_FINGER or seq >= SEQ_MODULO or values.min() < VALUE_MIN or values.max() > VALUE_MAX:
            stats.range_errors += 1
            return None, True
        return self._accept(finger, seq, values), True


def make_decoder(mode: str) -> BinaryDecoder | TextDecoder:
    if mode == "binary":
        return BinaryDecoder()
    if mode == "text":
        return TextDecoder()
    raise ValueError(f"serial mode must be 'binary' or 'text', got {mode!r}")
