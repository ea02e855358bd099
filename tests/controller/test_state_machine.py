"""The state machine ticked with scripted snapshots: every transition, faults, commands."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.controller.machine import ACTIVE, GraspController
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.kinematics.chain import HandKinematics
from grasp_ctrl.kinematics.fingertip import PAD_POINT_SENSOR

REACH = np.array([0.0, 0.0, 0.2])


class Script:
    """Builds snapshots; the palm 'arrives' wherever the controller sent it."""

    def __init__(self, hand, obj):
        self.hand = hand
        self.ctrl = GraspController(hand, obj, REACH)
        self.n = len(hand.fingers)
        self.t = 0.0
        self.palm = REACH + np.array([0.0, 0.0, 0.05])
        self.q = np.array([j.open_rad for j in hand.joints])
        self.cmd = None

    def snap(self, contact=False, grip=0.0, f_world_z=0.0, fault=None, tare=True, f_sensor=None):
        in_contact = np.zeros(self.n, dtype=bool)
        grips = np.zeros(self.n)
        if contact:
            in_contact[:] = [f.grasp for f in self.hand.fingers]
            grips[in_contact] = grip
        f_world = np.zeros((self.n, 3))
        f_world[:, 0] = grips
        f_world[:, 2] = f_world_z
        fs = np.zeros((self.n, 3)) if f_sensor is None else f_sensor
        return Snapshot(
            t=self.t,
            q=self.q,
            p_palm_world=self.palm.copy(),
            tare_ready=tare,
            in_contact=in_contact,
            f_sensor=fs,
            f_hand=f_world,
            f_world=f_world,
            grip_n=grips,
            fault=fault,
        )

    def tick(self, **kw):
        self.t += self.hand.dt
        self.cmd = self.ctrl.tick(self.snap(**kw))
        self.palm = self.cmd.p_palm_world.copy()  # an ideal arm
        return self.cmd

    def run_until(self, state, limit=5000, **kw):
        for _ in range(limit):
            if self.ctrl.state == state:
                return
            self.tick(**kw)
        raise AssertionError(f"never reached {state}, stuck in {self.ctrl.state}")


@pytest.fixture
def script(hand, objects):
    return Script(hand, objects["chips_can"])


def test_full_sequence_of_states(script):
    s = script
    s.tick(tare=False)
    assert s.ctrl.state == "tare"
    s.run_until("reach")
    s.run_until("close")
    assert np.linalg.norm(s.palm - REACH) < 1e-3
    s.tick(contact=True, grip=0.5)
    assert s.ctrl.state == "ramp"
    s.run_until("lift", contact=True, grip=2.0)
    s.run_until("hold", contact=True, grip=2.0, f_world_z=-0.5)
    assert s.palm[2] == pytest.approx(REACH[2] + s.ctrl.obj.lift_height_m, abs=1e-3)
    s.run_until("lower", contact=True, grip=2.0, f_world_z=-0.5)
    # While lowering, the index still holds the object up: no release.
    for _ in range(20):
        s.tick(contact=True, grip=2.0, f_world_z=-0.5)
    assert s.ctrl.state == "lower"
    # The table takes the load: the index pushes down -> release after the debounce.
    debounce = s.ctrl.obj.release_debounce
    for _ in range(debounce - 1):
        s.tick(contact=True, grip=2.0, f_world_z=+1.0)
    assert s.ctrl.state == "lower"
    s.tick(contact=True, grip=2.0, f_world_z=+1.0)
    assert s.ctrl.state == "release"
    s.run_until("retreat")
    s.run_until("done")
    assert [b for _, _, b in s.ctrl.history] == [
        "reach",
        "close",
        "ramp",
        "lift",
        "hold",
        "lower",
        "release",
        "retreat",
        "done",
    ]


def test_debounce_resets_on_a_single_positive_tick(script):
    s = script
    s.run_until("close")
    s.tick(contact=True, grip=2.0)
    s.run_until("lower", contact=True, grip=2.0, f_world_z=-0.5)
    for _ in range(s.ctrl.obj.release_debounce - 1):
        s.tick(contact=True, grip=2.0, f_world_z=+1.0)
    s.tick(contact=True, grip=2.0, f_world_z=-0.5)
    for _ in range(s.ctrl.obj.release_debounce - 1):
        s.tick(contact=True, grip=2.0, f_world_z=+1.0)
    assert s.ctrl.state == "lower"


@pytest.mark.parametrize(
    "drive,reason",
    [
        ("close", "no_contact"),
        ("ramp", "ramp_timeout"),
        ("lift", "slipped"),
        ("lower", "no_release"),
    ],
)
def test_guard_faults(script, drive, reason):
    s = script
    s.run_until("close")
    if drive == "close":
        s.run_until("fault")
    else:
        s.tick(contact=True, grip=0.5)
        if drive == "ramp":
            s.run_until("fault", contact=True, grip=0.5)
        elif drive == "lift":
            s.run_until("lift", contact=True, grip=2.0)
            s.run_until("fault", contact=False)
        else:
            s.run_until("lower", contact=True, grip=2.0, f_world_z=-0.5)
            s.run_until("fault", contact=True, grip=2.0, f_world_z=-0.5)
    assert s.ctrl.state == "fault"
    assert s.ctrl.failure_reason == reason


# Inputs that make each state move on to the next one.
ADVANCE = {
    "tare": {},
    "reach": {},
    "close": {"contact": True, "grip": 0.5},
    "ramp": {"contact": True, "grip": 2.0},
    "lift": {"contact": True, "grip": 2.0, "f_world_z": -0.5},
    "hold": {"contact": True, "grip": 2.0, "f_world_z": -0.5},
    "lower": {"contact": True, "grip": 2.0, "f_world_z": 1.0},
    "release": {},
    "retreat": {},
}


def drive_to(s: Script, target: str) -> None:
    for _ in range(5000):
        if s.ctrl.state == target:
            return
        s.tick(**ADVANCE[s.ctrl.state])
    raise AssertionError(f"never reached {target}")


@pytest.mark.parametrize("state", ACTIVE)
@pytest.mark.parametrize("fault", ["sensor_stale", "hardware_error", "aborted"])
def test_runner_faults_from_every_active_state(hand, objects, state, fault):
    s = Script(hand, objects["chips_can"])
    drive_to(s, state)
    assert s.ctrl.state == state
    s.tick(fault=fault, **ADVANCE[state])
    assert s.ctrl.state == "fault"
    assert s.ctrl.failure_reason == fault
    s.tick(**ADVANCE[state])
    assert s.ctrl.state == "fault"  # terminal: nothing leaves it


def test_overforce_faults(script, hand):
    s = script
    s.run_until("close")
    f = np.zeros((len(hand.fingers), 3))
    f[0, 2] = hand.safety.max_fingertip_force_n + 0.1
    s.tick(contact=True, grip=0.5, f_sensor=f)
    assert s.ctrl.failure_reason == "overforce"


@pytest.mark.parametrize("action", ["open", "hold", "torque_off"])
def test_safe_action(hand, objects, action):
    from dataclasses import replace

    h = replace(hand, safety=replace(hand.safety, on_fault=action))
    s = Script(h, objects["chips_can"])
    s.run_until("close")
    s.tick(contact=True, grip=0.5)
    s.run_until("lift", contact=True, grip=2.0)
    before = s.cmd.q_goal.copy()
    palm = s.palm.copy()
    for _ in range(100):
        s.tick(fault="sensor_stale")
    assert s.ctrl.state == "fault"
    np.testing.assert_allclose(s.cmd.p_palm_world, palm, atol=1e-9)  # arm stopped
    open_q = np.array([j.open_rad for j in h.joints])
    if action == "open":
        np.testing.assert_allclose(s.cmd.q_goal, open_q, atol=1e-9)
        assert s.cmd.torque_on
    elif action == "hold":
        np.testing.assert_allclose(s.cmd.q_goal, before, atol=1e-9)
        assert s.cmd.torque_on
    else:
        assert not s.cmd.torque_on


def test_close_moves_pads_along_task_vectors_within_limits(script, hand):
    s = script
    s.run_until("close")
    kin = HandKinematics(hand)

    def pads(q):
        out = {}
        for f in hand.fingers:
            T = kin.fk(f.name, q)
            out[f.name] = T[:3, :3] @ PAD_POINT_SENSOR + T[:3, 3]
        return out

    first = s.tick().q_goal
    p0 = pads(first)
    lower = np.array([j.lower_rad for j in hand.joints])
    upper = np.array([j.upper_rad for j in hand.joints])
    prev = first
    for _ in range(30):
        goal = s.tick().q_goal
        assert np.all(goal >= lower - 1e-12) and np.all(goal <= upper + 1e-12)
        assert np.max(np.abs(goal - prev)) <= hand.safety.max_joint_step_rad + 1e-12
        prev = goal
    p1 = pads(prev)
    for f in hand.fingers:
        d = p1[f.name] - p0[f.name]
        if f.grasp:
            v = np.array(f.task_vector_hand)
            assert np.dot(d, v) > 0.005, f.name  # moved toward the object
            assert np.linalg.norm(d - np.dot(d, v) * v) < 0.1 * np.linalg.norm(d), f.name
        else:
            assert np.linalg.norm(d) < 1e-9, f.name


def test_diagram_lists_every_transition_with_its_guard_and_fault_reason():
    from grasp_ctrl.controller.diagram import RUNTIME_FAULTS, mermaid
    from grasp_ctrl.controller.machine import ACTIVE, TRANSITIONS

    lines = mermaid().splitlines()
    assert lines[0] == "stateDiagram-v2" and "  [*] --> tare" in lines
    edges = [ln.strip() for ln in lines if "-->" in ln]
    for src, dst, guard, reason in TRANSITIONS:
        match = [e for e in edges if e.startswith(f"{src} --> {dst}: {guard} (")]
        assert len(match) == 1, (src, dst, guard)
        assert match[0].endswith(f"→ {reason}") if reason else "→" not in match[0]
    # Every active state reaches fault, and every fault edge names its reason.
    assert {e.split()[0] for e in edges if "--> fault" in e} == set(ACTIVE)
    assert all("→" in e for e in edges if "--> fault" in e)
    assert all(r in "\n".join(lines) for r in RUNTIME_FAULTS)
    # the hardening's fault reasons (sensing pipeline, controller, control tick) are runtime faults too
    assert {"sensor_invalid", "estimate_invalid", "goal_invalid"} <= set(RUNTIME_FAULTS)
    assert "Class" not in "\n".join(lines)  # no styling noise


def test_design_docs_diagram_is_the_diagram_commands_output(capsys):
    from pathlib import Path

    from grasp_ctrl.cli import main

    assert main(["diagram"]) == 0
    printed = capsys.readouterr().out.strip()
    design = (Path(__file__).resolve().parents[2] / "docs" / "design.md").read_text(encoding="utf-8")
    assert f"```mermaid\n{printed}\n```" in design


def test_diagram_picture(tmp_path):
    pytest.importorskip("matplotlib")
    from grasp_ctrl.cli import main

    for name in ("sm.svg", "sm.png"):
        assert main(["diagram", "--out", str(tmp_path / name)]) == 0
        assert (tmp_path / name).stat().st_size > 10_000
