"""Each joint's actuation facts in SI, whatever drives the hand: one home for the rules that the
simulated worlds, the grasp statics and the controller's stiffness model share.

Two kinds (the hand file's ``actuator``):

- ``dynamixel``: position-controlled servos. Stiffness and damping come from ``[dynamixel]
  position_p_gain``/``position_d_gain`` x each joint's ``gain_scale`` through the servo model's
  facts (config/servos.py); the torque limit is each joint's ``current_limit_a`` x the model's
  torque per amp; the joint's passive damping is the motor's back-EMF (stall torque / no-load
  speed); the servos report their current.
- ``torque_pd``: torque-controlled joints whose PD loop runs on the host (the Allegro v4 over
  CAN). Each joint's ``kp_nm_per_rad``, ``kd_nm_s_per_rad`` and ``torque_limit_nm`` are the
  file's; passive damping and armature are ``[torque_pd]``'s; the hand reports no current.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.servos import ServoModel, servo_model
from grasp_ctrl.errors import UsageError


def hand_servo(hand: HandConfig) -> ServoModel:
    """A Dynamixel hand's servo model: its own ``[servo_models.NAME]``, else config/servos.py's by
    ``[dynamixel] model``; a one-line error for a hand that has no servos."""
    if not hand.servo_driven:
        raise UsageError(f"hand {hand.name!r}: actuator = {hand.actuator!r} has no Dynamixel servo model")
    return hand.dynamixel.servo or servo_model(hand.dynamixel.model)


def require_dynamixel(hand: HandConfig, what: str) -> None:
    """A one-line error where ``what`` (a backend, a command) needs Dynamixel servos the hand lacks."""
    if not hand.servo_driven:
        raise UsageError(
            f"{what} drives Dynamixel servos; hand {hand.name!r} ({hand.path}) has actuator = {hand.actuator!r} "
            "(simulate it: run --backend mujoco or mock)"
        )


def torque_per_amp_nm(hand: HandConfig) -> float | None:
    """N m per A of the current the joints report (Dynamixel: stall torque / stall current);
    None for a hand that reports no current."""
    if not hand.servo_driven:
        return None
    return hand_servo(hand).torque_per_amp_nm


def torque_limits_nm(hand: HandConfig, torque_per_amp_nm: float | None = None) -> np.ndarray:
    """Each joint's largest torque (N m), hand-file order: its current limit's torque on a
    Dynamixel hand (at ``torque_per_amp_nm`` where a caller sets one, else the servo model's),
    its ``torque_limit_nm`` on a torque-controlled one."""
    if hand.servo_driven:
        per_amp = torque_per_amp_nm if torque_per_amp_nm is not None else hand_servo(hand).torque_per_amp_nm
        return np.array([j.current_limit_a for j in hand.joints]) * per_amp
    return np.array([_set(j.torque_limit_nm) for j in hand.joints])


def current_limits_a(hand: HandConfig) -> dict[str, float] | None:
    """Each joint's current limit by name (Dynamixel); None where the hand has no currents."""
    if not hand.servo_driven:
        return None
    return {j.name: j.current_limit_a for j in hand.joints}


@dataclass(frozen=True)
class PDGains:
    """Each joint's position stiffness and damping (hand-file order), or None with the reason."""

    kp_nm_per_rad: np.ndarray | None
    kv_nm_s_per_rad: np.ndarray | None
    reason: str


def pd_gains(hand: HandConfig, default_p_gain: float | None = None, default_d_gain: float | None = None) -> PDGains:
    """The joints' PD gains in SI. A Dynamixel hand without position gains in its file keeps the
    servos' own, unknown here: None, unless ``default_p_gain``/``default_d_gain`` (register
    units) stand in for them (the simulated worlds' assumption)."""
    if not hand.servo_driven:
        kp = np.array([_set(j.kp_nm_per_rad) for j in hand.joints])
        kv = np.array([_set(j.kd_nm_s_per_rad) for j in hand.joints])
        return PDGains(kp, kv, f"torque_pd kp_nm_per_rad: {kp.min():.3g} to {kp.max():.3g} N m/rad")
    d = hand.dynamixel
    p_gain = d.position_p_gain if d.position_p_gain is not None else default_p_gain
    d_gain = d.position_d_gain if d.position_d_gain is not None else default_d_gain
    if p_gain is None:
        return PDGains(
            None,
            None,
            f"hand {hand.name!r} sets no [dynamixel] position_p_gain (the servos keep gains this file does not know)",
        )
    if p_gain <= 0:
        return PDGains(
            None, None, f"hand {hand.name!r}: [dynamixel] position_p_gain = {p_gain} (no position stiffness)"
        )
    model = hand_servo(hand)
    if model.stall_torque_nm is None:
        return PDGains(
            None,
            None,
            f"hand {hand.name!r}: servo model {model.name} has no stall torque in "
            "config/servos.py (its stiffness is unknown)",
        )
    scale = np.array([j.gain_scale for j in hand.joints])
    servo_kp = model.kp_nm_per_rad(p_gain) * scale
    servo_kv = model.kv_nm_s_per_rad(d_gain) * scale if d_gain is not None else None
    return PDGains(
        servo_kp,
        servo_kv,
        f"[dynamixel] position_p_gain = {p_gain} x gain_scale: kp {servo_kp.min():.3g} to {servo_kp.max():.3g} N m/rad",
    )


def passive_damping_nm_s_per_rad(hand: HandConfig) -> float:
    """The joint's damping besides the PD's: a Dynamixel's back-EMF under voltage drive (stall
    torque / no-load speed), a torque-controlled hand's ``[torque_pd] damping_nm_s_per_rad``."""
    if hand.torque_pd is not None:
        return hand.torque_pd.damping_nm_s_per_rad
    model = hand_servo(hand)
    if model.stall_torque_nm is None:
        raise UsageError(f"servo model {model.name}: no stall torque known here (the joints' damping)")
    return model.stall_torque_nm / model.no_load_speed_rad_s


def armature_kg_m2(hand: HandConfig) -> float | None:
    """The joints' reflected rotor inertia where the hand file gives it; None: the world's default."""
    return hand.torque_pd.armature_kg_m2 if hand.torque_pd is not None else None


def describe(hand: HandConfig) -> str:
    """One line on what limits the joints' torque, for command headers."""
    if hand.servo_driven:
        model = hand_servo(hand)
        return f"servos at their current limits x {model.torque_per_amp_nm:.3f} N m/A ({model.name})"
    limits = torque_limits_nm(hand)
    return f"torque-controlled joints, limits {limits.min():.3g} to {limits.max():.3g} N m"


def _set(value: float | None) -> float:
    if value is None:  # not reached: config/hand_sections.py requires every torque_pd key
        raise UsageError("a torque_pd joint without its gains or torque limit")
    return value
