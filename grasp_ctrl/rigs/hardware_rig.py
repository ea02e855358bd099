"""Open the real backends named by a hand file: Dynamixel (or CAN) hand, arm, serial sensors."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import UsageError
from grasp_ctrl.hardware.base import ArmBackend, Clock, HandBackend, SensorBackend
from grasp_ctrl.rigs.closing import close_all


@dataclass
class HardwareRig:
    hand: HandBackend
    arm: ArmBackend
    sensors: SensorBackend
    clock: Clock

    def close(self) -> None:
        """Stop everything; the hand last, so its safe stop runs with the arm halted."""
        close_all(self.arm, self.sensors, self.hand, raise_error=False)


def open_rig(
    hand: HandConfig,
    port: str | None = None,
    sensor_port: str | None = None,
    ask: Callable[[str], str] | None = None,
) -> HardwareRig:
    """Connect the hand, the arm and the fingertip sensors of ``hand``.

    ``port`` overrides ``[dynamixel] port`` (a CAN hand's ``[torque_pd] channel``); ``sensor_port`` overrides the tactile
    port(s); ``ask`` answers the external arm's prompts (default: the terminal).
    """
    from grasp_ctrl.hardware.dynamixel import DynamixelHand
    from grasp_ctrl.hardware.dynamixel.hand import MonotonicClock
    from grasp_ctrl.tactile_link.serial_sensors import SerialSensors

    if hand.arm.kind == "mock":
        raise UsageError(f"{hand.path}: arm.kind: 'external' or 'dynamixel' for a real hand ('mock' moves nothing)")
    clock = MonotonicClock()
    opened: list[HandBackend | ArmBackend | SensorBackend] = []
    try:
        if hand.servo_driven:
            hand_backend: HandBackend = DynamixelHand(hand, port, clock=clock)
        else:  # a torque-controlled hand on CAN (the Allegro); ``port`` names its CAN channel
            from grasp_ctrl.hardware.allegro import AllegroCANHand

            hand_backend = AllegroCANHand(hand, port, clock=clock)
        hand_backend.connect()
        opened.append(hand_backend)
        if hand.arm.kind == "dynamixel":
            from grasp_ctrl.hardware.arm_dynamixel import DynamixelArm

            arm: ArmBackend = DynamixelArm(hand)
        else:
            from grasp_ctrl.hardware.arm_external import ExternalArm

            arm = ExternalArm(hand, ask=ask)
        arm.connect()
        opened.append(arm)
        sensors = SerialSensors.from_hand(hand, port=sensor_port, clock=clock)
        sensors.start()
        opened.append(sensors)
    except BaseException:
        close_all(*reversed(opened), raise_error=False)
        raise
    return HardwareRig(hand_backend, arm, sensors, clock)
