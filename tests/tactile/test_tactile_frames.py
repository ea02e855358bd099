"""Raw frame validation: length, 12-bit range, NaN/inf -> FrameError with a clear message."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES, FRAME_LEN
from grasp_ctrl.errors import FrameError, GraspCtrlError
from grasp_ctrl.tactile.frames import validate_frames

counts = st.integers(min_value=0, max_value=4095)


@given(st.lists(st.lists(counts, min_size=FRAME_LEN, max_size=FRAME_LEN), min_size=1, max_size=5))
def test_valid_frames_pass_unchanged(rows: list[list[int]]) -> None:
    out = validate_frames(rows)
    assert out.shape == (len(rows), FRAME_LEN)
    assert np.array_equal(out, np.array(rows, dtype=float))


def test_single_frame_becomes_a_batch_of_one() -> None:
    assert validate_frames(np.full(FRAME_LEN, 2000)).shape == (1, FRAME_LEN)


@pytest.mark.parametrize("n", [0, 1, 43, 45, 88])
def test_wrong_length_is_rejected(n: int) -> None:
    with pytest.raises(FrameError, match=rf"expected 44 values per fingertip.*got shape .*\b{n} values"):
        validate_frames(np.full((2, n), 100))


@settings(max_examples=60)
@given(
    row=st.integers(0, 3),
    col=st.integers(0, FRAME_LEN - 1),
    bad=st.one_of(
        st.just(float("nan")),
        st.just(float("inf")),
        st.just(-float("inf")),
        st.floats(min_value=-1e9, max_value=-0.5),
        st.floats(min_value=4095.5, max_value=1e9),
    ),
)
def test_any_bad_value_is_rejected_naming_fingertip_and_channel(row: int, col: int, bad: float) -> None:
    frames = np.full((4, FRAME_LEN), 2048.0)
    frames[row, col] = bad
    fingers = ["index", "middle", "ring", "thumb"]
    with pytest.raises(FrameError) as info:
        validate_frames(frames, fingers)
    msg = str(info.value)
    assert f"fingertip {fingers[row]!r}" in msg
    assert f"channel {CHANNEL_NAMES[col]} " in msg
    assert isinstance(info.value, GraspCtrlError)  # the CLI prints it as one line


def test_non_numeric_is_rejected() -> None:
    with pytest.raises(FrameError, match="not a numeric array"):
        validate_frames([["a"] * FRAME_LEN])


def test_the_frame_layout_is_the_sensor_types():
    """The hand file's sensor type names its frame layout; an unknown type is one line."""
    import pytest

    from grasp_ctrl.config.sensor_layout import BIOTAC, FRAME_LEN, LAYOUTS, layout_for
    from grasp_ctrl.errors import UsageError

    assert layout_for("biotac") is BIOTAC and set(LAYOUTS) == {"biotac"}
    assert BIOTAC.frame_len == FRAME_LEN == 44 and BIOTAC.channel_names[BIOTAC.pdc] == "pdc"
    assert BIOTAC.channel_names[BIOTAC.tdc] == "tdc" and BIOTAC.channel_names[BIOTAC.pac][0] == "pac1"
    with pytest.raises(UsageError, match="unknown"):
        layout_for("digit")
