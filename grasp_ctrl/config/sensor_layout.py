"""Channel layout of a tactile sensor's frame, by sensor type (the hand file's
``[tactile] sensor_type``).

The BioTac is the one type today: 44 values in the paper's order,
z = [e1..e19, pdc, pac1..pac22, tdc, tac], raw 12-bit counts. The module-level
constants are the BioTac's (the compiled kernels read them as constants); code that
serves any sensor asks ``layout_for(hand.tactile.sensor_type)``. A new sensor type is
a new ``SensorLayout`` entry plus estimators that read it.
"""

from __future__ import annotations

from dataclasses import dataclass

from grasp_ctrl.errors import UsageError


@dataclass(frozen=True)
class SensorLayout:
    """Where each channel sits in one frame, and the range of a raw value."""

    name: str
    channel_names: tuple[str, ...]
    electrodes: slice  # the impedance electrodes
    pdc: int  # static pressure
    pac: slice  # dynamic pressure samples
    tdc: int  # static temperature
    tac: int  # dynamic temperature
    count_min: int
    count_max: int

    @property
    def frame_len(self) -> int:
        return len(self.channel_names)

    @property
    def n_electrodes(self) -> int:
        return self.electrodes.stop - self.electrodes.start


BIOTAC = SensorLayout(
    name="biotac",
    channel_names=tuple(f"e{i}" for i in range(1, 20))
    + ("pdc",)
    + tuple(f"pac{i}" for i in range(1, 23))
    + ("tdc", "tac"),
    electrodes=slice(0, 19),
    pdc=19,
    pac=slice(20, 42),
    tdc=42,
    tac=43,
    count_min=0,
    count_max=4095,  # 12-bit ADC counts on the real sensor
)

#: Every known sensor type, by the name the hand file and policy metadata use.
LAYOUTS: dict[str, SensorLayout] = {BIOTAC.name: BIOTAC}


def layout_for(sensor_type: str) -> SensorLayout:
    try:
        return LAYOUTS[sensor_type]
    except KeyError:
        raise UsageError(f"sensor_type {sensor_type!r}: unknown (one of {', '.join(LAYOUTS)})") from None


# The BioTac's layout as constants, for the kernels and the BioTac-specific code.
N_ELECTRODES = BIOTAC.n_electrodes
N_PAC = BIOTAC.pac.stop - BIOTAC.pac.start
FRAME_LEN = BIOTAC.frame_len
ELECTRODES = BIOTAC.electrodes
PDC = BIOTAC.pdc
PAC = BIOTAC.pac
TDC = BIOTAC.tdc
TAC = BIOTAC.tac
COUNT_MIN = BIOTAC.count_min
COUNT_MAX = BIOTAC.count_max
CHANNEL_NAMES: tuple[str, ...] = BIOTAC.channel_names

assert FRAME_LEN == 44 and N_PAC == 22 and N_ELECTRODES == 19
