"""Cost of the tactile serial link on the host (protocol v1 decoding).

``tactile_decode_4tips_ms``: decoding one 100 Hz sample of 4 fingertips (4 binary
frames, 384 bytes, fed as one chunk) into frames, i.e. the reader thread's CPU
time per control tick.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.bench.figure import Figure, time_ms
from grasp_ctrl.tactile_link.decoder import BinaryDecoder
from grasp_ctrl.tactile_link.protocol import encode_binary


def decode_4tips(quick: bool) -> Figure:
    rng = np.random.default_rng(0)
    chunks = [b"".join(encode_binary(tip, k % 65536, rng.integers(0, 4096, 44)) for tip in range(4)) for k in range(64)]
    dec = BinaryDecoder()
    state = {"k": 0}

    def one_tick() -> None:
        frames = dec.feed(chunks[state["k"] % 64])
        state["k"] += 1
        assert len(frames) == 4

    return time_ms(one_tick, repeats=200 if quick else 5000, warmup=20)


FIGURES = {"tactile_decode_4tips_ms": decode_4tips}
