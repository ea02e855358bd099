"""The grip-load controller's rules on scripted force traces: the load phase, grip-load
coordination, the slip response, the safety and crush caps, the release near the support,
and the ramp's steady rule under quantised jitter. MuJoCo checks are in test_grip_load_mujoco.py."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.controller.grip_load import LOAD_STATES, GripLoadController
from grasp_ctrl.controller.grip_load_settings import GripLoadSettings
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.ramp_settle import RampSettle, TrendRampSettle
from grasp_ctrl.controller.registry import controller_class, controller_names, make_controller, settings_for
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.errors import UsageError

REACH = np.array([0.0, 0.0, 0.2])
GRIP_LOAD = settings_for("grip_load")


class Trace:
    """Snapshots whose forces a test scripts; the palm arrives wherever the controller sent it."""

    def __init__(self, hand, obj, settings=GRIP_LOAD):
        self.hand = hand
        self.ctrl = make_controller(hand, obj, REACH, settings)
        self.n = len(hand.fingers)
        self.grasp = np.array([f.grasp for f in hand.fingers])
        self.t = 0.0
        self.palm = REACH + np.array([0.0, 0.0, 0.05])
        self.q = np.array([j.open_rad for j in hand.joints])

    def snap(self, grips=None, loads=None, contact=True, tare=True):
        """``grips``: each fingertip's grip (N, horizontal); ``loads``: the upward force each
        fingertip exerts on the object (N): f_world z = -load on the sensor."""
        grips = np.zeros(self.n) if grips is None else np.asarray(grips, dtype=float)
        loads = np.zeros(self.n) if loads is None else np.asarray(loads, dtype=float)
        in_contact = self.grasp.copy() if contact else np.zeros(self.n, dtype=bool)
        grips = np.where(in_contact, grips, 0.0)
        f_world = np.zeros((self.n, 3))
        f_world[:, 0] = grips
        f_world[:, 2] = np.where(in_contact, -loads, 0.0)
        f_sensor = np.zeros((self.n, 3))
        f_sensor[:, 2] = grips
        f_sensor[:, 0] = np.where(in_contact, loads, 0.0)
        return Snapshot(self.t, self.q, self.palm.copy(), tare, in_contact, f_sensor, f_world, f_world, grips)

    def tick(self, **kw):
        self.t += self.hand.dt
        cmd = self.ctrl.tick(self.snap(**kw))
        self.palm = cmd.p_palm_world.copy()  # an ideal arm
        return cmd

    def run_until(self, state, limit=3000, **kw):
        for _ in range(limit):
            if self.ctrl.state == state:
                return
            self.tick(**kw)
        raise AssertionError(f"never reached {state}, stuck in {self.ctrl.state}")

    def at_target(self):
        """Each grasping fingertip exactly at its current target."""
        return np.where(self.grasp, self.ctrl.grip_targets, 0.0)


@pytest.fixture
def mustard(objects):
    return objects["mustard_bottle"]


def _to_load(tr: Trace) -> None:
    tr.run_until("close", contact=False)
    tr.tick(grips=np.full(tr.n, 0.5))
    assert tr.ctrl.state == "ramp"
    for _ in range(500):
        if tr.ctrl.state != "ramp":
            break
        tr.tick(grips=tr.at_target())
    assert tr.ctrl.state == "load"


def test_registry_names_both_controllers_and_refuses_others(hand, mustard):
    assert controller_names() == ("paper", "grip_load")
    assert controller_class("paper") is GraspController
    assert isinstance(make_controller(hand, mustard, REACH, GRIP_LOAD), GripLoadController)
    assert isinstance(make_controller(hand, mustard, REACH), GripLoadController)  # the default
    paper = make_controller(hand, mustard, REACH, settings_for("paper"))
    assert type(paper) is GraspController
    with pytest.raises(UsageError, match="one of paper, grip_load"):
        controller_class("pid")


def test_the_load_state_sits_between_ramp_and_lift(hand, mustard):
    assert LOAD_STATES.index("load") == LOAD_STATES.index("ramp") + 1 == LOAD_STATES.index("lift") - 1
    tr = Trace(hand, mustard)
    _to_load(tr)
    z0 = tr.palm[2]
    weight = mustard.mass_kg * 9.81
    share = np.where(tr.grasp, weight / tr.grasp.sum(), 0.0)
    # the palm rises slowly while the fingertips carry nothing yet: the state waits for the minimum rise
    for _ in range(50):
        tr.tick(grips=tr.at_target(), loads=np.zeros(tr.n))
    rise = tr.palm[2] - z0
    assert tr.ctrl.state == "load"
    assert rise == pytest.approx(50 * tr.hand.dt * tr.ctrl.s.load.load_speed_m_s, rel=0.05)
    # once the weight hangs in the grasp and the palm has risen the minimum, the lift starts
    tr.run_until("lift", grips=tr.at_target(), loads=share)
    assert tr.palm[2] - z0 >= tr.ctrl.s.load.load_min_rise_m - 1e-9


def test_load_ends_at_the_maximum_rise_when_the_weight_never_shows(hand, mustard):
    tr = Trace(hand, mustard)
    _to_load(tr)
    z0 = tr.palm[2]
    tr.run_until("lift", grips=tr.at_target(), loads=np.zeros(tr.n))
    assert tr.palm[2] - z0 == pytest.approx(tr.ctrl.s.load.load_max_rise_m, abs=1e-3)


def test_grip_follows_the_load_within_the_friction_cone(hand, mustard):
    tr = Trace(hand, mustard)
    _to_load(tr)
    ctrl = tr.ctrl
    base = ctrl.base_targets.copy()
    # a load on the index that needs more grip than tau: margin x load / mu > base
    loads = np.zeros(tr.n)
    i = ctrl.names.index("index")
    loads[i] = 1.05 * ctrl.mu_hat * base[i] / ctrl.s.coordination.grip_margin  # (the thumb's cap: 1.07)
    for k in range(1, 41):  # the load rises at 2.5 N/s: no slip
        tr.tick(grips=tr.at_target(), loads=loads * min(1.0, k / 30))
    expected = ctrl.s.coordination.grip_margin * loads[i] / (ctrl.mu_hat * base[i])
    assert ctrl.slip_events == 0
    assert ctrl.scale == pytest.approx(expected, rel=1e-6)
    assert np.allclose(ctrl.grip_targets, base * expected)  # every target keeps its proportion
    # the load goes slowly: the scale follows it down at most grip_relax_per_s
    scales = []
    for k in range(1, 41):
        tr.tick(grips=tr.at_target(), loads=loads * max(0.0, 1.0 - k / 30))
        scales.append(ctrl.scale)
    steps = np.diff([expected, *scales])
    assert np.all(steps <= 1e-12) and np.all(steps >= -ctrl.s.coordination.grip_relax_per_s * tr.hand.dt - 1e-12)
    assert scales[-1] < expected


def test_a_falling_grip_is_a_slip_that_raises_the_grip_and_stops_the_arm(hand, objects):
    tr = Trace(hand, objects["chips_can"])  # (equal targets: far from the safety cap)
    _to_load(tr)
    ctrl = tr.ctrl
    tr.run_until("lift", grips=tr.at_target(), loads=np.zeros(tr.n))
    for _ in range(10):
        tr.tick(grips=tr.at_target())
    before, z = ctrl.scale, tr.palm[2]
    grips = tr.at_target()
    thumb = ctrl.names.index("thumb")
    for k in range(1, 6):  # the thumb's grip falls 0.5 N a tick (50 N/s)
        g = grips.copy()
        g[thumb] -= 0.5 * k
        tr.tick(grips=g)
    relaxed = 5 * ctrl.s.coordination.grip_relax_per_s * tr.hand.dt  # the boost relaxes like the load's need
    assert ctrl.slip_events == 1 and ctrl.scale >= before + ctrl.s.coordination.slip_boost - relaxed - 1e-9
    assert tr.palm[2] == pytest.approx(z, abs=1e-9)  # the arm waits while the fingertip slips


def test_the_load_near_the_cone_is_a_slip(hand, mustard):
    tr = Trace(hand, mustard, GRIP_LOAD.replace(grip_margin=1.0))
    _to_load(tr)
    ctrl = tr.ctrl
    loads = np.zeros(tr.n)
    i = ctrl.names.index("middle")
    grips = tr.at_target()
    loads[i] = 0.95 * ctrl.mu_hat * grips[i]  # above slip_cone_fraction (0.9) of the cone
    tr.tick(grips=grips, loads=loads)
    assert ctrl.slipping[i] and ctrl.slip_events == 1


def test_the_safety_limit_caps_the_grip_with_the_tangential_force(hand, mustard):
    tr = Trace(hand, mustard)
    _to_load(tr)
    ctrl = tr.ctrl
    loads = np.where(tr.grasp, 50.0, 0.0)  # asks for far more than the fingertips may give
    tr.tick(grips=tr.at_target(), loads=loads)
    cap = ctrl.grip_cap_n
    assert cap == pytest.approx(hand.safety.max_fingertip_force_n * ctrl.s.limits.grip_cap_fraction)
    assert max(ctrl.grip_targets) <= cap + 1e-9


def test_a_deformable_object_is_never_gripped_near_its_crush_force(hand, objects):
    cup = objects["paper_cup"]
    tr = Trace(hand, cup)
    _to_load(tr)
    tr.tick(grips=tr.at_target(), loads=np.where(tr.grasp, 10.0, 0.0))
    assert max(tr.ctrl.grip_targets) <= cup.crush_force_n * tr.ctrl.s.limits.grip_cap_fraction + 1e-9


def test_the_ramp_scales_down_below_the_safety_limit(hand, mustard):
    tr = Trace(hand, mustard)
    tr.run_until("close", contact=False)
    tr.tick(grips=np.full(tr.n, 0.5))
    ctrl = tr.ctrl
    grips = tr.at_target()
    thumb = ctrl.names.index("thumb")
    snap_loads = np.zeros(tr.n)
    snap_loads[thumb] = 6.0  # the thumb on a rim: as much shear as normal force, |f| > the cap
    tr.tick(grips=grips, loads=snap_loads)
    f = np.hypot(grips[thumb], 6.0)
    assert ctrl.scale == pytest.approx(max(ctrl.s.limits.min_grip_scale, ctrl.grip_cap_n / f))


@pytest.mark.parametrize("state", ["ramp", "load"])
def test_a_pad_near_the_safety_limit_unwinds_its_fingers_goal_to_the_measured_angles(hand, mustard, state):
    """The scripted hand never moves (its joints stay open), so every closed goal is wound far past
    them: a pad above ``unwind_fraction`` of the limit brings its own finger's goal back to the
    measured angles (then one squeeze step), and leaves the other fingers' goals alone."""
    tr = Trace(hand, mustard)
    if state == "load":
        _to_load(tr)
    else:
        tr.run_until("close", contact=False)
        tr.tick(grips=np.full(tr.n, 0.5))
    assert tr.ctrl.state == state
    ctrl = tr.ctrl
    thumb = ctrl.names.index("thumb")
    rows_thumb, rows_index = ctrl.kin.slices["thumb"], ctrl.kin.slices["index"]
    limit = hand.safety.max_fingertip_force_n
    grips = tr.at_target()
    grips[thumb] = 0.85 * limit  # above the cap, below the unwind share: the goal stays wound
    tr.tick(grips=grips)
    assert np.max(np.abs(ctrl.motion.q_goal[rows_thumb] - tr.q[rows_thumb])) > 0.1
    index_goal = ctrl.motion.q_goal[rows_index].copy()
    grips[thumb] = 0.95 * limit
    tr.tick(grips=grips)
    step = ctrl.s.ramp_max_speed_m_s * hand.dt * 50  # one squeeze step, in rad, generously
    assert np.max(np.abs(ctrl.motion.q_goal[rows_thumb] - tr.q[rows_thumb])) < step
    assert np.max(np.abs(ctrl.motion.q_goal[rows_index] - index_goal)) < step
    assert np.max(np.abs(ctrl.motion.q_goal[rows_index] - tr.q[rows_index])) > 0.1


def test_a_stalled_joints_goal_stays_within_its_saturation_deflection(hand, mustard):
    """The scripted hand never moves, as a joint at its current limit does not: the squeeze keeps
    asking for force, but no grasping joint's goal runs further from its measured angle than
    ``windup_lag_factor`` times the deflection at which its servo saturates. Without the bound
    (factor 0) the same ticks wind the goals much further."""
    far = {}
    for factor in (1.5, 0.0):
        tr = Trace(hand, mustard, GRIP_LOAD.replace(windup_lag_factor=factor))
        tr.run_until("close", contact=False)
        tr.tick(grips=np.full(tr.n, 0.5))
        assert tr.ctrl.state == "ramp"
        for _ in range(150):
            tr.tick(grips=np.full(tr.n, 0.5))  # far below every target: the squeeze pushes on
        grasping = tr.ctrl._grasp_joints
        far[factor] = np.abs(tr.ctrl.motion.q_goal - tr.q)[grasping]
        if factor:
            bound = tr.ctrl.lag_bound_rad
            assert bound is not None
            assert np.all(np.abs(tr.ctrl.motion.q_goal - tr.q)[grasping] <= bound[grasping] + 1e-12)
    assert far[0.0].max() > 2.0 * far[1.5].max()


def test_release_near_the_support_reads_the_carried_sum_not_one_fingertip(hand, objects):
    lego = objects["lego"]
    tr = Trace(hand, lego)
    _to_load(tr)
    ctrl = tr.ctrl
    names = ctrl.names
    # a couple: index and middle push up 0.8 N each, the thumb down 0.9 N (the weight, 0.6 N, in all)
    couple = np.zeros(tr.n)
    couple[names.index("index")], couple[names.index("middle")], couple[names.index("thumb")] = 0.8, 0.8, -0.9
    tr.run_until("lower", grips=tr.at_target(), loads=couple)
    # high above the table the couple shifts (the index's share halves): no release
    shifted = couple.copy()
    shifted[names.index("index")] = 0.4
    shifted[names.index("thumb")] = -0.5
    for _ in range(20):
        tr.tick(grips=tr.at_target(), loads=shifted)
    assert ctrl.state == "lower"
    # near the support the sum falls to nothing: released after the debounce
    tr.run_until("release", grips=tr.at_target(), loads=np.zeros(tr.n))
    assert tr.palm[2] - REACH[2] < ctrl.s.lower_slow_zone_m


def test_the_paper_release_rule_still_fires(hand, mustard):
    tr = Trace(hand, mustard, GRIP_LOAD.replace(release_relative=False))
    _to_load(tr)
    tr.run_until("lower", grips=tr.at_target(), loads=np.where(tr.grasp, 1.5, 0.0))
    loads = np.where(tr.grasp, 1.5, 0.0)
    loads[tr.ctrl.release_idx] = -(mustard.release_threshold_n + 0.1)
    for _ in range(mustard.release_debounce + 1):
        tr.tick(grips=tr.at_target(), loads=loads)
    assert tr.ctrl.state == "release"


def test_the_lost_grip_floor_stays_on_the_tuned_targets(hand, objects):
    tr = Trace(hand, objects["chips_can"])
    _to_load(tr)
    ctrl = tr.ctrl
    loads = np.zeros(tr.n)
    loads[[ctrl.names.index("index"), ctrl.names.index("middle")]] = 3.0
    tr.tick(grips=tr.at_target(), loads=loads)
    assert ctrl.scale > 1.5
    grips = ctrl.base_targets * 0.5  # half the tuned targets: short of the raised ones, not lost
    for _ in range(20):
        tr.tick(grips=np.where(tr.grasp, grips, 0.0))
    assert ctrl.state != "fault"


def _jitter(n_ticks: int, spread: float, drift: float, seed: int = 0) -> np.ndarray:
    """Errors of three fingertips: a quantised jitter of +-spread around a mean drifting by ``drift`` N/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_ticks) * 0.01
    steps = rng.integers(-1, 2, size=(n_ticks, 3)) * spread
    # the grips sit at the band's edge: outside the tolerance, inside the balance band
    return np.array([0.25, -0.25, 0.05]) + steps + drift * t[:, None]


@pytest.mark.parametrize("seed", range(5))
def test_the_trend_rule_settles_a_jittering_steady_grasp_where_the_window_rule_cannot(seed):
    settings = GripLoadSettings()
    window, trend = RampSettle(settings), TrendRampSettle(settings)
    window_settled = trend_settled = False
    for err in _jitter(300, 0.2, 0.0, seed):  # the guard is read every tick
        window.update(err)
        trend.update(err)
        window_settled |= window.settled(0.01)
        trend_settled |= trend.settled(0.01)
    assert trend_settled and not window_settled


def test_the_trend_rule_does_not_settle_a_drifting_grasp():
    trend = TrendRampSettle(GripLoadSettings())
    for err in _jitter(300, 0.2, -0.3, 1)[:100]:  # the grips still rise 0.3 N/s
        trend.update(err)
        assert not trend.settled(0.01)


def _rocking(n_ticks: int, amplitude: float, drift: float = 0.0) -> np.ndarray:
    """Errors of three fingertips: the index and middle at their targets, the thumb's error cycling
    +-``amplitude`` every 0.6 s (a light object rocking on the table), all drifting by ``drift`` N/s."""
    t = np.arange(n_ticks) * 0.01
    err = np.zeros((n_ticks, 3))
    err[:, 2] = amplitude * np.sin(2.0 * np.pi * t / 0.6)
    return err + drift * t[:, None]


@pytest.mark.parametrize("cycle_s", [1.5, 0.0])
def test_the_cycle_rule_settles_a_grasp_rocking_about_its_targets(cycle_s):
    """The lego's limit cycle: no tick-to-tick rule holds (the thumb swings +-1 N), the cycle rule
    ends the ramp after ``ramp_cycle_s``; without it (0) the ramp never settles."""
    trend = TrendRampSettle(GripLoadSettings().replace(ramp_cycle_s=cycle_s))
    ticks = None
    for k, err in enumerate(_rocking(600, 1.0)):
        trend.update(err)
        if trend.settled(0.01):
            ticks = k + 1
            break
    if cycle_s:
        assert ticks is not None and ticks >= int(cycle_s / 0.01)
    else:
        assert ticks is None


@pytest.mark.parametrize(("amplitude", "drift"), [(1.5, 0.0), (1.0, -0.3)])
def test_the_cycle_rule_does_not_settle_a_wide_swing_or_a_drift(amplitude, drift):
    """A swing wider than ``ramp_cycle_swing_n`` (+-1.5 N: 3 N) or a cycle whose mean still moves."""
    trend = TrendRampSettle(GripLoadSettings())
    for err in _rocking(600, amplitude, drift):
        trend.update(err)
        assert not trend.settled(0.01)


@pytest.mark.parametrize("limited_s", [0.5, 0.0])
def test_a_finger_at_its_servos_limit_scales_the_ramp_targets_to_what_it_gives(hand, mustard, limited_s):
    """The scripted hand never moves, so every goal soon sits at its wind-up bound, as a finger's
    does when its servos give all they can: a thumb whose grip stays at 70 % of its target for
    ``servo_limited_s`` scales every target to 70 %; fingers at their targets do not; 0: never."""
    tr = Trace(hand, mustard, GRIP_LOAD.replace(servo_limited_s=limited_s))
    tr.run_until("close", contact=False)
    tr.tick(grips=np.full(tr.n, 0.5))
    ctrl = tr.ctrl
    assert ctrl.state == "ramp"
    thumb = ctrl.names.index("thumb")
    base = ctrl.grip_targets.copy()
    for _ in range(120):
        grips = tr.at_target()
        grips[thumb] = 0.7 * base[thumb]
        tr.tick(grips=grips)
        if ctrl.scale < 1.0:
            break
    if limited_s:
        assert ctrl.scale == pytest.approx(0.7)
        assert np.allclose(ctrl.grip_targets, 0.7 * base)
    else:
        assert ctrl.scale == 1.0


def test_the_off_values_of_the_servo_limit_rules_read_back_from_run_json():
    """0 turns the wind-up bound, the servo-limited targets and the cycle rule off: a run.json that
    recorded 0 resumes; a negative value is refused on one line."""
    from grasp_ctrl.trials.runs.manifest import settings_from_json

    off = {"windup_lag_factor": 0.0, "servo_limited_s": 0.0, "ramp_cycle_s": 0.0}
    s = settings_from_json({"controller": "grip_load", **off}, "run.json")
    assert (s.limits.windup_lag_factor, s.limits.servo_limited_s, s.cycle.ramp_cycle_s) == (0.0, 0.0, 0.0)
    with pytest.raises(UsageError, match="settings.ramp_cycle_s"):
        settings_from_json({"ramp_cycle_s": -1.0}, "run.json")
    with pytest.raises(UsageError, match="settings.ramp_cycle_swing_n"):
        settings_from_json({"ramp_cycle_swing_n": 0.0}, "run.json")
