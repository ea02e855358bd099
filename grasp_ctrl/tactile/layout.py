"""Channel layout of one BioTac frame (44 values, the paper's order).

z = [e1..e19, pdc, pac1..pac22, tdc, tac], raw counts.
"""

from __future__ import annotations

N_ELECTRODES = 19
N_PAC = 22
FRAME_LEN = 44

ELECTRODES = slice(0, 19)
PDC = 19
PAC = slice(20, 42)
TDC = 42
TAC = 43

# Raw values are 12-bit ADC counts on the real sensor.
COUNT_MIN = 0
COUNT_MAX = 4095

CHANNEL_NAMES: tuple[str, ...] = (
    tuple(f"e{i}" for i in range(1, 20))
    + ("pdc",)
    + tuple(f"pac{i}" for i in range(1, 23))
    + ("tdc", "tac")
)

assert len(CHANNEL_NAMES) == FRAME_LEN
