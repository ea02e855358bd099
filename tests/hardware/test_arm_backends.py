"""The Dynamixel arm (vertical line, against the emulator) and the external arm mode."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.hand import HandConfig, load_hand
from grasp_ctrl.emulators.dxl_chain import DynamixelChainEmulator
from grasp_ctrl.errors import ConfigError, HardwareError
from grasp_ctrl.hardware.arm_dynamixel import DynamixelArm, arm_chain
from grasp_ctrl.hardware.arm_external import ExternalArm
from grasp_ctrl.hardware.base import ArmBackend
from grasp_ctrl.hardware.dynamixel.calibration import Calibration
from tests.dxl_helpers import LEAP

ARM = """
[[arm.joints]]
name = "shoulder"
servo_id = 20
axis = [0.0, 1.0, 0.0]
lower_rad = -1.5
upper_rad = 1.5
open_rad = -0.3

[[arm.joints]]
name = "elbow"
servo_id = 21
axis = [0.0, 1.0, 0.0]
origin_xyz = [0.2, 0.0, 0.0]
lower_rad = -1.5
upper_rad = 1.5
open_rad = 0.6
"""


def arm_hand(tmp_path: Path, extra: str = ARM, kind: str = "dynamixel") -> HandConfig:
    text = LEAP.read_text()
    text = text.replace(
        'kind = "mock"',
        f'kind = "{kind}"\nbase_xyz = [0.0, 0.0, 0.3]\ntool_xyz = [0.2, 0.0, 0.0]\nmodel = "XM430-W350-T"',
        1,
    )
    path = tmp_path / "hand_with_arm.toml"
    path.write_text(text + extra)
    return load_hand(path)


def test_arm_config_needs_joints(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="arm.joints"):
        arm_hand(tmp_path, extra="")


def test_dynamixel_arm_lifts_along_a_vertical_line(tmp_path: Path) -> None:
    hand = arm_hand(tmp_path)
    q0 = np.array([j.open_rad for j in hand.arm.joints])
    counts = Calibration.from_joints(hand.arm.joints).to_counts_float(q0)
    with DynamixelChainEmulator([20, 21], model_number=1020, initial_counts={20: counts[0], 21: counts[1]}) as emu:
        arm = DynamixelArm(hand, emu.port)
        assert isinstance(arm, ArmBackend)
        arm.connect()
        try:
            p0 = arm.position()
            np.testing.assert_allclose(p0, arm_chain(hand).fk_rp(q0)[1], atol=2e-3)
            target = p0 + np.array([0.05, 0.0, 0.02])  # x is ignored: the axis only lifts
            xs = []
            for _ in range(80):
                arm.command(target)
                time.sleep(hand.dt * 0.5)
                xs.append(arm.position())
            time.sleep(0.3)
            p1 = arm.position()
            assert p1[2] == pytest.approx(p0[2] + 0.02, abs=2e-3)
            path = np.array(xs)
            assert np.max(np.abs(path[:, 0] - p0[0])) < 3e-3  # stayed on the line
            assert np.max(np.abs(path[:, 1] - p0[1])) < 1e-9
            # the set point never moved faster than max_speed per tick
            assert arm.z_set == pytest.approx(p0[2] + 0.02, abs=1e-6)
            arm.command(np.array([0.0, 0.0, 5.0]))  # clamped to z_max, one speed-limited step
            assert arm.z_set - (p0[2] + 0.02) == pytest.approx(hand.arm.max_speed_m_s * hand.dt)
        finally:
            arm.close()


def test_dynamixel_arm_reports_a_missing_servo(tmp_path: Path) -> None:
    hand = arm_hand(tmp_path)
    with DynamixelChainEmulator([20], model_number=1020) as emu:
        with pytest.raises(HardwareError, match=r"elbow \(id 21\)"):
            DynamixelArm(hand, emu.port).connect()


def scripted(answers: list[str]):
    prompts: list[str] = []

    def ask(text: str) -> str:
        prompts.append(text)
        if not answers:
            raise EOFError
        return answers.pop(0)

    return ask, prompts


def test_external_arm_waits_for_confirmations(tmp_path: Path) -> None:
    hand = arm_hand(tmp_path, extra="", kind="external")
    ask, prompts = scripted(["", "", "0.1 0.0 0.33", ""])
    arm = ExternalArm(hand, ask=ask, start_world=np.array([0.1, 0.0, 0.30]))
    assert isinstance(arm, ArmBackend)
    arm.connect()
    assert len(prompts) == 1
    # a lift of 5 cm commanded in 1 mm ticks: asks each confirm_step (2 cm) ...
    z = 0.30
    while z < 0.35 - 1e-9:
        z = min(0.35, z + 0.001)
        arm.command(np.array([0.1, 0.0, z]))
    assert len(prompts) == 3 and "0.320" in prompts[1] and "0.340" in prompts[2]
    # ... the operator reported the arm actually stopped at 0.33
    assert arm.position()[2] == pytest.approx(0.33)
    arm.command(np.array([0.1, 0.0, 0.35]))  # the command rests at 0.35: confirm the end point
    assert len(prompts) == 4 and arm.position()[2] == pytest.approx(0.35)
    arm.command(np.array([0.1, 0.0, 0.35]))
    assert len(prompts) == 4


def test_external_arm_abort_and_closed_input(tmp_path: Path) -> None:
    hand = arm_hand(tmp_path, extra="", kind="external")
    ask, _ = scripted(["abort"])
    arm = ExternalArm(hand, ask=ask)
    with pytest.raises(HardwareError) as info:
        arm.connect()
    assert info.value.reason == "aborted"
    ask, _ = scripted([])
    with pytest.raises(HardwareError, match="input closed"):
        ExternalArm(hand, ask=ask).connect()
