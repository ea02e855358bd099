"""counts <-> rad with per-joint offset and sign."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from grasp_ctrl.hardware.dynamixel.control_table import RAD_PER_COUNT


def cal(offset: float, sign: int, lo: float = -1.0, hi: float = 1.5) -> Calibration:
    return Calibration(np.array([offset]), np.array([float(sign)]), np.array([lo]), np.array([hi]))


@given(st.floats(-1.0, 1.0), st.sampled_from([-1, 1]), st.floats(-1.0, 1.5))
def test_round_trip_within_half_a_count(offset: float, sign: int, q: float) -> None:
    c = cal(offset, sign)
    back = c.to_rad(c.to_counts(np.array([q])))
    # half a count of rounding; within a count of a limit, rounding goes inward (up to 1 count)
    near_limit = min(q - (-1.0), 1.5 - q) < RAD_PER_COUNT
    assert abs(back[0] - q) <= (1.0 if near_limit else 0.5) * RAD_PER_COUNT + 1e-12


@given(st.floats(-1.0, 1.0), st.sampled_from([-1, 1]), st.floats(-20.0, 20.0))
def test_goal_counts_never_leave_the_limits(offset: float, sign: int, q: float) -> None:
    c = cal(offset, sign)
    back = c.to_rad(c.to_counts(np.array([q])))[0]
    assert -1.0 - 1e-9 <= back <= 1.5 + 1e-9


def test_offset_and_sign_meaning() -> None:
    # joint zero sits 0.5 rad (servo direction) from the servo centre; the servo turns backwards
    c = cal(0.5, -1)
    zero = c.to_counts_float(np.array([0.0]))[0]
    assert zero == 2048 + 0.5 / RAD_PER_COUNT
    assert c.to_counts_float(np.array([0.1]))[0] < zero
    assert c.velocity_to_rad_s(np.array([10]))[0] < 0
