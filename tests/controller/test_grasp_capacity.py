"""Statics of the grasp (controller/grasp_capacity.py, ``lift-capacity``): the liftable weight
balances the pads' forces, scales with the servos' torque and friction, and on the shipped LEAP
mount names the two heavy boxes that slip in MuJoCo (docs/mujoco.md)."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.config.actuation import torque_per_amp_nm
from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.controller.grasp_capacity import GRAVITY_M_S2, liftable_weight, object_capacity
from grasp_ctrl.files.paths import default_hand_file, default_objects_file


@pytest.fixture(scope="module")
def hand():
    return load_hand(default_hand_file())


@pytest.fixture(scope="module")
def objects():
    return load_objects(default_objects_file())


@pytest.fixture(scope="module")
def cleanser_grasp(hand, objects):
    return object_capacity(hand, objects["cleanser"])


def test_pads_touch_the_box_sides_facing_each_other(cleanser_grasp, objects) -> None:
    _, contacts, _ = cleanser_grasp
    half = 0.5 * objects["cleanser"].size_m[0]
    assert [c.finger for c in contacts] == ["index", "middle", "thumb"]
    for c in contacts:
        assert abs(abs(c.point_hand[0]) - half) < 5e-4  # on the side, within the closing step
        np.testing.assert_allclose(c.normal_hand, [np.sign(c.point_hand[0]), 0.0, 0.0], atol=1e-9)
        assert c.facing_deg < 15.0  # the preshape faces the pads to the side (the thumb within 12 deg)


def test_the_best_grasp_carries_the_weight_within_friction_and_torque(cleanser_grasp, objects) -> None:
    cap, _, _ = cleanser_grasp
    mu = objects["cleanser"].mu
    assert cap.weight_n > 0.0
    # horizontal normals: the lifts alone carry the weight
    assert sum(ld.lift_n for ld in cap.loads) == pytest.approx(cap.weight_n, rel=1e-6)
    for ld in cap.loads:
        assert ld.normal_n >= 0.0 and abs(ld.lift_n) <= mu * ld.normal_n + 1e-6
        assert ld.torque_share <= 1.0 + 1e-6


@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_capacity_scales_with_the_servo_torque(hand, objects, cleanser_grasp, factor: float) -> None:
    cap, contacts, q = cleanser_grasp
    per_amp = torque_per_amp_nm(hand)
    assert per_amp == pytest.approx(0.93 / 1.8)  # the hand file's servo model (XC330-M288-T)
    scaled = liftable_weight(hand, q, contacts, objects["cleanser"].mu, torque_per_amp_nm=per_amp * factor)
    assert scaled.weight_n == pytest.approx(factor * cap.weight_n, rel=1e-6)


def test_more_friction_never_lifts_less(hand, cleanser_grasp) -> None:
    _, contacts, q = cleanser_grasp
    weights = [liftable_weight(hand, q, contacts, mu).weight_n for mu in (0.3, 0.6, 1.0, 1.5)]
    assert all(b >= a - 1e-9 for a, b in zip(weights, weights[1:]))
    assert weights[0] < weights[-1]


def test_shipped_hand_carries_every_default_object_with_margin(hand, objects) -> None:
    """The shipped hand (thumb_mcp raised to 1.2 A) carries every object at least 1.3x its weight;
    at the LEAP API's 0.55 A everywhere the heavy boxes are beyond the thumb's MCP servo."""
    import dataclasses

    for name, obj in objects.items():
        cap, _, _ = object_capacity(hand, obj)
        assert cap.weight_n / (obj.mass_kg * GRAVITY_M_S2) >= 1.3, name
    low = dataclasses.replace(
        hand,
        fingers=tuple(
            dataclasses.replace(f, joints=tuple(dataclasses.replace(j, current_limit_a=0.55) for j in f.joints))
            for f in hand.fingers
        ),
    )
    for name in ("cleanser", "mustard_bottle"):
        cap, _, _ = object_capacity(low, objects[name])
        assert cap.weight_n / (objects[name].mass_kg * GRAVITY_M_S2) < 1.0, name
        assert {ld.finger: ld.joint for ld in cap.loads if ld.torque_share > 0.999}["thumb"] == "thumb_mcp"


def test_cli_exit_codes(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lift-capacity", "--variation", "nominal", "--min-margin", "1.3"]) == 0
    assert main(["lift-capacity", "--min-margin", "3"]) == 1
    assert "below 3x the weight: cleanser, mustard_bottle" in capsys.readouterr().out
    assert main(["lift-capacity", "--objects", "lego", "chips_can", "--min-margin", "2"]) == 0
    assert main(["lift-capacity", "--objects", "nope"]) == 2
    assert "unknown object" in capsys.readouterr().err
