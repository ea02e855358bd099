"""``hand-check``: the first thing to run with a new hand (ping, read, optionally move)."""

from __future__ import annotations

import argparse
import time
from typing import Any

NAME = "hand-check"
HOT_MARGIN_C = 5  # flag a servo this close to its Temperature Limit (it shuts down there)
HELP = (
    "ping every servo of a Dynamixel hand (or ask an Allegro on CAN), print its state, optionally "
    "move each joint a little"
)
DESCRIPTION = (
    "Pings every configured servo (reports missing ids and model mismatches by joint name), reads "
    "Hardware Error Status (bits by name), temperature, input voltage and the present "
    "position/velocity/current, flags joints outside their limits, servos within "
    f"{HOT_MARGIN_C} degC of their temperature limit and input voltages outside their voltage limits. "
    "Read-only unless --move (configure, torque on, move each joint by --step within its "
    "limits and back, then torque off) or --recover (reboot servos that report a hardware error). "
    "Exits 0 when everything is fine, 1 otherwise. A torque-controlled hand on CAN (actuator = "
    '"torque_pd", the Allegro): asks for its information, serial number, temperatures and joint '
    "positions (--port names the CAN channel; python-can: pip install -e '.[can]')."
)
ORDER = 40


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file

    add_hand_file(p)
    p.add_argument(
        "--port", default=None, metavar="PORT", help="serial port (default: [dynamixel] port of the hand file)"
    )
    p.add_argument("--baud", type=int, default=None, help="baud rate (default: the hand file's)")
    p.add_argument("--move", action="store_true", help="move each joint by --step and back (torque on!)")
    p.add_argument("--step", type=float, default=0.1, metavar="RAD", help="test motion per joint (default 0.1 rad)")
    p.add_argument("--recover", action="store_true", help="reboot servos that report a hardware error")


def run(args: argparse.Namespace) -> int:
    import dataclasses

    import numpy as np

    from grasp_ctrl.config.actuation import require_dynamixel
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.hardware.dynamixel import DynamixelHand
    from grasp_ctrl.hardware.dynamixel import control_table as ct

    if not 0.0 < args.step <= 0.5:
        raise UsageError(f"--step: expected 0 < RAD <= 0.5, got {args.step}")
    hand = load_hand(args.hand)
    if hand.torque_pd is not None:  # a torque-controlled hand on CAN (the Allegro)
        return _can_hand_check(hand, args)
    require_dynamixel(hand, "hand-check")
    if args.baud:
        hand = dataclasses.replace(hand, dynamixel=dataclasses.replace(hand.dynamixel, baud=args.baud))
    dxl = DynamixelHand(hand, args.port)
    bus = dxl.bus
    bus.open()
    problems: list[str] = []
    try:
        from grasp_ctrl.hardware.dynamixel.port import set_low_latency

        print(f"hand-check: {hand.name} ({len(dxl.ids)} servos) on {bus.port_name} at {hand.dynamixel.baud} baud")
        print(f"  {set_low_latency(bus.port_name, hand.dynamixel.latency_timer_ms)}")
        print(
            f"  {'joint':14s} {'id':>3s}  {'model':14s} {'hw_error':18s} {'temp_C':>6s} {'input_V':>7s} "
            f"{'q_rad':>8s} {'counts':>7s} {'dq_rad_s':>8s} {'current_A':>9s}  status"
        )
        answered = 0
        for k, j in enumerate(dxl.joints):
            model, why = bus.ping(j.servo_id)
            if model is None:
                problems.append(f"{j.name} (id {j.servo_id}): no reply")
                print(
                    f"  {j.name:14s} {j.servo_id:3d}  {'-':14s} {'-':18s} {'':>6s} {'':>7s} {'':>8s} {'':>7s} {'':>8s} {'':>9s}  MISSING ({why})"
                )
                continue
            answered += 1
            found = ct.model_by_number(model)
            model_name = found.name if found else f"model {model}"
            status: list[str] = []  # shown in the table
            bad: list[str] = []  # also counted as problems
            if dxl.model is not None and model != dxl.model.model_number:
                bad.append(f"MODEL MISMATCH (expected {dxl.model.name})")
            hw = bus.read(j.servo_id, ct.ADDR_HARDWARE_ERROR_STATUS, 1)
            if hw and args.recover:
                bus.reboot(j.servo_id)
                time.sleep(0.3)
                status.append(f"rebooted (was {','.join(ct.hardware_error_names(hw))})")
                hw = bus.read(j.servo_id, ct.ADDR_HARDWARE_ERROR_STATUS, 1)
            hw_text = f"{','.join(ct.hardware_error_names(hw))} (0x{hw:02x})" if hw else "-"
            if hw:
                bad.append(
                    f"HARDWARE ERROR {','.join(ct.hardware_error_names(hw))} (status 0x{hw:02x}; run with --recover)"
                )
            temp_c, volts, supply_problems = _thermal_and_supply(bus, j.servo_id)
            bad += supply_problems
            counts = bus.read(j.servo_id, ct.ADDR_PRESENT_POSITION, 4, signed=True)
            vel = bus.read(j.servo_id, ct.ADDR_PRESENT_VELOCITY, 4, signed=True)
            cur = bus.read(j.servo_id, ct.ADDR_PRESENT_CURRENT, 2, signed=True)
            sel = slice(k, k + 1)
            cal = dataclasses.replace(
                dxl.cal,
                offset_rad=dxl.cal.offset_rad[sel],
                sign=dxl.cal.sign[sel],
                lower_rad=dxl.cal.lower_rad[sel],
                upper_rad=dxl.cal.upper_rad[sel],
            )
            q = float(cal.to_rad(np.array([counts]))[0])
            dq = float(cal.velocity_to_rad_s(np.array([vel]))[0])
            amps = float(cal.sign[0] * cur * dxl.amp_per_unit)
            if not j.lower_rad - 1e-3 <= q <= j.upper_rad + 1e-3:
                bad.append(f"OUTSIDE LIMITS [{j.lower_rad}, {j.upper_rad}] (check offset/sign)")
            problems.extend(f"{j.name} (id {j.servo_id}): {s}" for s in bad)
            status = bad + status
            print(
                f"  {j.name:14s} {j.servo_id:3d}  {model_name:14s} {hw_text:18s} {temp_c:6d} {volts:7.1f} "
                f"{q:8.3f} {counts:7d} {dq:8.3f} {amps:9.3f}  {'; '.join(status) or 'ok'}"
            )
        print(
            f"  {answered}/{len(dxl.ids)} servos answered; bus: {bus.stats.comm_errors} communication errors, {bus.stats.retries} retries"
        )
    finally:
        bus.close()

    return _conclude(hand, args, problems)


def _conclude(hand: Any, args: argparse.Namespace, problems: list[str]) -> int:
    """The move test (``--move``, only on a hand without problems), then the verdict: exit 0, or
    one error naming every problem."""
    from grasp_ctrl.errors import HardwareError

    if args.move and not problems:
        problems += _move_test(hand, args.port, args.step)
    if problems:
        raise HardwareError(f"hand-check found {len(problems)} problem(s): " + "; ".join(problems))
    print("hand-check: OK")
    return 0


def _thermal_and_supply(bus, dxl_id: int) -> tuple[int, float, list[str]]:
    """(temperature degC, input voltage V, problems), judged against the servo's own limit
    registers (a limit register reading 0 is treated as unknown)."""
    from grasp_ctrl.hardware.dynamixel import control_table as ct

    out: list[str] = []
    temp_c = bus.read(dxl_id, ct.ADDR_PRESENT_TEMPERATURE, 1)
    temp_limit = bus.read(dxl_id, ct.ADDR_TEMPERATURE_LIMIT, 1)
    if temp_limit and temp_c >= temp_limit - HOT_MARGIN_C:
        out.append(f"HOT {temp_c} degC (shuts down at {temp_limit} degC; let it cool)")
    volts = bus.read(dxl_id, ct.ADDR_PRESENT_INPUT_VOLTAGE, 2) * ct.VOLT_PER_UNIT
    v_max = bus.read(dxl_id, ct.ADDR_MAX_VOLTAGE_LIMIT, 2) * ct.VOLT_PER_UNIT
    v_min = bus.read(dxl_id, ct.ADDR_MIN_VOLTAGE_LIMIT, 2) * ct.VOLT_PER_UNIT
    if v_max and not v_min <= volts <= v_max:
        out.append(f"INPUT VOLTAGE {volts:.1f} V outside {v_min:.1f}-{v_max:.1f} V (check the supply)")
    return temp_c, volts, out


def _move_test(hand, port: str | None, step: float) -> list[str]:
    """Each joint in turn: +-step (toward the middle of its range) and back, within the step limit."""
    import numpy as np

    from grasp_ctrl.hardware.dynamixel import DynamixelHand

    problems: list[str] = []
    print(f"move test: each joint by {step:.3f} rad and back (torque on)")
    opened: Any = DynamixelHand(hand, port) if hand.servo_driven else _can_hand(hand, port)
    with opened as dxl:
        home = dxl.read().q.copy()
        for k, j in enumerate(dxl.joints):
            direction = 1.0 if home[k] + step <= j.upper_rad else -1.0
            target = home.copy()
            target[k] = float(np.clip(home[k] + direction * step, j.lower_rad, j.upper_rad))
            reached = _drive(dxl, target, k)
            err = abs(reached - target[k])
            ok = err < max(0.02, 0.2 * step)
            back = _drive(dxl, home, k)
            verdict = "ok" if ok else "DID NOT REACH (blocked? current limit? sign?)"
            print(f"  {j.name:14s} goal {target[k]:+.3f}  reached {reached:+.3f}  back {back:+.3f}  {verdict}")
            if not ok:
                problems.append(f"{j.name} (id {j.servo_id}): moved to {reached:.3f} rad, goal {target[k]:.3f}")
            if hand.servo_driven:
                dxl.check_health(force=True)
            else:
                dxl.check_health()
        dxl.safe_stop("torque_off")
    return problems


def _drive(dxl, target, k: int, timeout_s: float = 1.5) -> float:
    import numpy as np

    end = time.monotonic() + timeout_s
    # The goal the hand can hold: a posture read back a count outside a joint limit is clamped
    # to it, and waiting for the unclamped target would always run out the timeout.
    reachable = np.clip(target, dxl.lower, dxl.upper)
    q = dxl.read().q
    while time.monotonic() < end:
        dxl.write_goals(target)
        time.sleep(dxl.hand.dt)
        q = dxl.read().q
        if np.allclose(dxl.last_goal, reachable) and abs(q[k] - reachable[k]) < 0.01:
            break
    return float(q[k])


def _can_hand(hand: Any, channel: str | None) -> Any:
    from grasp_ctrl.hardware.allegro import AllegroCANHand

    return AllegroCANHand(hand, channel)


def _can_hand_check(hand: Any, args: argparse.Namespace) -> int:
    """The Allegro on CAN, read-only: hand information (versions, side, temperature, status bits),
    serial number, the four temperatures and every joint's position, each asked for once (remote
    frames); nothing is written unless --move."""
    import numpy as np

    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.hardware.allegro import protocol as pr
    from grasp_ctrl.hardware.allegro.bus import open_link
    from grasp_ctrl.hardware.allegro.protocol import JointMap, ProtocolError

    if args.recover:
        raise UsageError("--recover: the Allegro has no reboot command on CAN; power-cycle the hand")
    if args.baud:
        raise UsageError("--baud: a CAN hand's bit rate is [torque_pd] bitrate (socketcan: set with `ip link`)")
    tp = hand.torque_pd
    jm = JointMap.from_hand(hand)
    link = open_link(tp, args.port)
    dev = jm.device_id
    replies: dict[Any, Any] = {}
    problems: list[str] = []
    try:
        print(f"hand-check: {hand.name} ({len(hand.joints)} joints) on CAN {link.name}, device id {dev}")
        requests = [pr.request(pr.RTR_HAND_INFO, dev), pr.request(pr.RTR_SERIAL, dev)]
        requests += [pr.request_temperature(i, dev) for i in range(pr.N_TEMPERATURE_SENSORS)]
        requests += [pr.request_finger_pose(f, dev) for f in range(pr.N_FINGERS)]
        for req in requests:
            link.send(req)
        end = time.monotonic() + 0.3
        while time.monotonic() < end:
            frame = link.recv(0.02)
            if frame is None or frame.device_id != dev:
                continue
            if frame.is_error:
                problems.append("CAN error frame (bus errors or bus-off: wiring, termination, bit rate)")
                continue
            try:
                reply = pr.decode_reply(frame)
            except ProtocolError:
                continue
            key = type(reply).__name__ + str(getattr(reply, "finger", getattr(reply, "sensor", "")))
            replies[key] = reply
    finally:
        link.close()
    info = replies.get("HandInfo")
    if info is None:
        problems.append("no hand information (powered? on this bus at 1 Mbit/s? terminated?)")
    else:
        side = "right" if info.right_hand else "left"
        print(
            f"  hardware version {info.hardware_version}, firmware 0x{info.firmware_version:04x}, {side} hand, "
            f"{info.temperature_c} degC, status 0x{info.status:02x} (servo {'on' if info.servo_on else 'off'})"
        )
        problems += [f"the hand reports {f}" for f in info.faults()]
        if info.hardware_version != 4 and tp.pwm_per_nm == 1200.0:
            problems.append(
                f"hardware version {info.hardware_version}: the v4's 1200 PWM per N m does not apply "
                "(a v3 takes 800: set [torque_pd] pwm_per_nm and pwm_limit)"
            )
    serial = replies.get("str")
    print(f"  serial number: {serial if serial is not None else '- (no reply)'}")
    temps = [replies.get(f"Temperature{i}") for i in range(pr.N_TEMPERATURE_SENSORS)]
    print("  temperatures: " + ", ".join(f"{t.celsius} degC" if t else "-" for t in temps))
    for t in temps:
        if t is not None and t.celsius > tp.max_temperature_c:
            problems.append(f"temperature sensor {t.sensor}: {t.celsius} degC (limit {tp.max_temperature_c:g})")
    counts = np.zeros((pr.N_FINGERS, pr.JOINTS_PER_FINGER), dtype=np.int64)
    answered = set()
    for f in range(pr.N_FINGERS):
        pose = replies.get(f"FingerPose{f}")
        if pose is not None:
            counts[f] = pose.counts
            answered.add(f)
    q = jm.joints_rad(counts)
    print(f"  {'joint':14s} {'finger':>6s} {'slot':>4s} {'counts':>7s} {'q_rad':>8s}  status")
    for k, j in enumerate(hand.joints):
        finger, slot = int(jm.finger[k]), int(jm.slot[k])
        if finger not in answered:
            problems.append(f"{j.name} (finger {finger}): no position reply")
            print(f"  {j.name:14s} {finger:6d} {slot:4d} {'':>7s} {'':>8s}  MISSING")
            continue
        status = "ok"
        if not j.lower_rad - 1e-3 <= q[k] <= j.upper_rad + 1e-3:
            status = f"OUTSIDE LIMITS [{j.lower_rad}, {j.upper_rad}] (check offset_rad/sign)"
            problems.append(f"{j.name}: {status}")
        print(f"  {j.name:14s} {finger:6d} {slot:4d} {int(counts[finger, slot]):7d} {q[k]:8.3f}  {status}")
    return _conclude(hand, args, problems)
