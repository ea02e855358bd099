"""One control tick over any backends (mock or real), docs/design.md 3.

read health and sensors -> snapshot (tare, gate, estimate, frames) -> controller
-> one goal write and one arm command. Faults of the hardware become the
snapshot's ``fault``, so the state machine decides and stops safely.
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.config.sensor_layout import PAC
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.errors import FrameError, HardwareError
from grasp_ctrl.hardware.base import ArmBackend, HandBackend, SensorBackend
from grasp_ctrl.loop.loop_kernels import PAIRWISE_BLOCK, row_spreads
from grasp_ctrl.loop.sensing import SensingPipeline
from grasp_ctrl.numeric.finite import both_finite


def control_tick(
    hand: HandBackend,
    arm: ArmBackend,
    sensors: SensorBackend,
    pipeline: SensingPipeline,
    ctrl: GraspController,
    now: float,
    fault: str | None = None,
) -> tuple[Snapshot, Command, np.ndarray]:
    """Returns the snapshot, the command sent and the raw frames used."""
    raw = pipeline.raw
    detail = None
    try:
        hand.check_health()
        check_stale = getattr(sensors, "check_stale", None)
        if check_stale is not None:  # the serial backend can also tell an unplugged port
            check_stale(now)
        raw = pipeline.read_frames(sensors, now)
    except HardwareError as exc:
        if fault is None:
            fault, detail = exc.reason, str(exc)  # the record names what failed
    except FrameError as exc:
        if fault is None:
            fault, detail = "sensor_invalid", str(exc)
    spread = pac_spread(raw) if ctrl.reads_vibration and raw is not None else None
    snap = pipeline.snapshot(raw, hand.read(), arm.position(), ctrl.state == "tare", fault, detail, spread)
    cmd = send_command(hand, arm, ctrl, snap, ctrl.tick(snap))
    return snap, cmd, raw


_PAC_START, _N_PAC = PAC.start, PAC.stop - PAC.start
assert _N_PAC <= PAIRWISE_BLOCK  # (row_spreads sums in numpy's order up to there)


def pac_spread(raw: np.ndarray) -> np.ndarray:
    """(n_tips, 44) raw frames -> (n_tips,) standard deviation of each frame's 22 PAC samples (counts):
    ``std(axis=1)``'s values, bit for bit, in one compiled pass (``row_spreads``)."""
    frames = np.ascontiguousarray(raw, dtype=float)
    out = np.empty(frames.shape[0])
    row_spreads(frames, _PAC_START, _N_PAC, out)
    return out


def send_command(hand: HandBackend, arm: ArmBackend, ctrl: GraspController, snap: Snapshot, cmd: Command) -> Command:
    """The controller's command to the hand and the arm; returns what was sent."""
    if not both_finite(np.asarray(cmd.q_goal), np.asarray(cmd.p_palm_world)):
        # Never send a non-finite goal: fault, and command the safe action from the measured pose.
        if not ctrl.terminal:
            ctrl.fail(reason="goal_invalid", detail=f"controller computed a non-finite goal in state {ctrl.state!r}")
        cmd = ctrl.safe_command(snap)
    if not cmd.torque_on:
        hand.set_torque(False)
    hand.write_goals(cmd.q_goal)
    arm.command(cmd.p_palm_world)
    return cmd
