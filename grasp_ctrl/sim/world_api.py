"""What a simulated world offers the trial code: the ``World`` protocol.

The runner steps a world and reads its clock and events, the judge (trials/episode/
outcome.py) its ground truth, the oracle policy its true forces, the tick log and the
recorders its state. ``MockWorld`` (sim/mock/world.py) and ``MuJoCoWorld`` (sim/mujoco/world.py)
both satisfy it; a new simulator is added by writing a world that does, and a backend
entry for it (rigs/registry.py).
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class World(Protocol):
    """A simulated hand, arm, object, table and fingertip sensors, stepped one control period at a time."""

    # clock
    t: float  # simulated time (s)

    def step(self) -> None:
        """Advance one control period (the hand file's dt)."""

    def set_phase(self, state: str) -> None:
        """The controller's state, for events and world-side logging."""

    def close(self) -> None:
        """End of the trial (e.g. finish a video); idempotent."""

    # what the backends read and write (sim/mock/backends.py)
    q: np.ndarray  # joint angles (rad)
    q_goal: np.ndarray  # joint goals the hand backend writes (rad)
    torque_on: bool
    palm_target: np.ndarray  # the arm's target (m, world frame)
    palm_world: np.ndarray  # the palm's position (m, world frame)
    raw: np.ndarray  # (n_tips, 44) raw tactile frames (counts)
    seq: np.ndarray  # per-fingertip frame counters
    sensor_ids: list[str]

    # ground truth: the judge, the oracle and the tick log
    f_sensor: np.ndarray  # (n_tips, 3) true force on each skin (N, sensor frame)
    normal_n: np.ndarray  # (n_tips,) true normal force (N)
    obj_z: float  # object height (m)
    max_obj_z: float  # highest object height so far (m)
    table_n: float  # the table's force on the object (N)
    crushed: bool
    knocked_over: bool
    events: list[Any]  # world events of the trial (contacts, crushing, falls)
    draw: dict[str, Any]  # this trial's variation draw (sim/variation.py; the record's variation_draw)
    dt: float  # the control period (s)

    def true_f_sensor(self, finger: str) -> np.ndarray:
        """The true force on ``finger``'s skin (N, sensor frame): what the oracle policy reads."""

    # what the servos see (the emulated hand's servo chain reads and writes these)
    q_measured: np.ndarray  # the joint angles the servos report (rad, less any calibration offsets)
    joint_current_a: np.ndarray  # the servos' present current (A)

    def command_goal(self, q_measured_goal: np.ndarray) -> None:
        """A goal in the servos' calibrated angles (what a hand backend writes)."""

    def reach_pose_world(self) -> np.ndarray:
        """The palm's pre-grasp position (m, world frame)."""
