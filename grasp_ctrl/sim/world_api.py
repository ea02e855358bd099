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

from grasp_ctrl.sim.world_parts import WorldEvent


@runtime_checkable
class World(Protocol):
    """A simulated hand, arm, object, table and fingertip sensors, stepped one control period at a
    time. Read-only members are properties here: a world may keep them as plain attributes."""

    # clock
    t: float  # simulated time (s)

    @property
    def dt(self) -> float:
        """The control period (s)."""

    def step(self) -> None:
        """Advance one control period (the hand file's dt)."""

    def set_phase(self, state: str) -> None:
        """The controller's state, for events and world-side logging."""

    def close(self) -> object:
        """End of the trial (e.g. finish a video: then its path); idempotent."""

    # what the backends write (sim/world_backends.py)
    q_goal: np.ndarray  # the joints' goals (rad, true angles: calibration offsets included)
    torque_on: bool
    palm_target: np.ndarray  # the arm's target (m, world frame)

    def command_goal(self, q_measured_goal: np.ndarray) -> None:
        """A goal in the servos' calibrated angles (what a hand backend writes)."""

    # what the backends read: the servos' view (the emulated hand's servo chain too)
    @property
    def q_measured(self) -> np.ndarray:
        """The joint angles the servos report (rad, less any calibration offsets)."""

    @property
    def q_goal_measured(self) -> np.ndarray:
        """The goal the servos hold (rad, calibrated: the last ``command_goal``)."""

    @property
    def joint_current_a(self) -> np.ndarray:
        """The servos' present current (A)."""

    @property
    def palm_world(self) -> np.ndarray:
        """The palm's position (m, world frame)."""

    @property
    def raw(self) -> np.ndarray:
        """(n_tips, 44) raw tactile frames (counts)."""

    @property
    def seq(self) -> int:
        """The frames' counter (16 bits, as the sensors' serial stream)."""

    @property
    def sensor_ids(self) -> list[int]:
        """Each fingertip's sensor id, in hand-file finger order."""

    def reach_pose_world(self) -> np.ndarray:
        """The palm's pre-grasp position (m, world frame)."""

    # ground truth: the judge, the oracle and the tick log
    @property
    def q(self) -> np.ndarray:
        """The joints' true angles (rad)."""

    @property
    def f_sensor(self) -> np.ndarray:
        """(n_tips, 3) true force on each skin (N, sensor frame)."""

    @property
    def normal_n(self) -> np.ndarray:
        """(n_tips,) true normal force (N)."""

    @property
    def obj_z(self) -> float:
        """The object's height (m)."""

    @property
    def max_obj_z(self) -> float:
        """The object's highest height so far (m)."""

    @property
    def table_n(self) -> float:
        """The table's force on the object (N)."""

    @property
    def crushed(self) -> bool: ...

    @property
    def knocked_over(self) -> bool: ...

    @property
    def events(self) -> list[WorldEvent]:
        """The trial's world events (contacts, crushing, falls)."""

    @property
    def draw(self) -> dict[str, Any]:
        """This trial's variation draw (sim/variation.py; the record's ``variation_draw``)."""

    def true_f_sensor(self, finger: str) -> np.ndarray:
        """The true force on ``finger``'s skin (N, sensor frame): what the oracle policy reads."""
