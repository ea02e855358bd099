"""What the controller sees each tick, and what it asks for."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Snapshot(NamedTuple):
    """One control tick's view of the world; guards read only this and the object profile.

    Per-fingertip arrays are in hand-file finger order. Immutable (a named tuple: made
    every tick, at a fraction of a frozen dataclass's cost); ``_replace`` makes a changed copy.
    """

    t: float  # s
    q: np.ndarray  # measured joint angles, rad
    p_palm_world: np.ndarray  # m
    tare_ready: bool
    in_contact: np.ndarray  # (n_tips,) bool, debounced pdc gate
    f_sensor: np.ndarray  # (n_tips, 3) N, estimated force on the skin (0 without contact)
    f_hand: np.ndarray  # (n_tips, 3) N
    f_world: np.ndarray  # (n_tips, 3) N
    grip_n: np.ndarray  # (n_tips,) N, squeeze: |f_world| across the lift direction
    variance: np.ndarray | None = None  # (n_tips, 3) N^2 when the policy provides it
    fault: str | None = None  # a fault the runner detected (sensor_stale, hardware_error, aborted, ...)
    fault_detail: str | None = None  # what failed, in words (servo id and error bits, port, fingertip)
    # (n_tips,) raw counts: the spread of each fingertip's 22 PAC samples in this tick's frame
    # (vibration: slip), for a controller that reads it (``reads_vibration``); None otherwise
    pac_spread: np.ndarray | None = None


class Command(NamedTuple):
    q_goal: np.ndarray  # rad
    p_palm_world: np.ndarray  # arm target, m
    torque_on: bool = True
