"""The paper controller's two readings of its ramp (settings.RAMP_MODES) and a hand file's own
controller choices ([controllers.NAME]): push_then_hold pushes each pad forward only, ends the ramp
once every pad has reached its target, then holds the finger goals while the arm lifts and lowers;
regulate (the LEAP Hand's) keeps regulating every pad. A choice names its file and key when wrong."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grasp_ctrl.config.hand import load_hand
from grasp_ctrl.config.objects import load_objects
from grasp_ctrl.controller.grip_load import GripLoadController
from grasp_ctrl.controller.machine import GraspController
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import flat_settings, settings_for
from grasp_ctrl.controller.snapshot import Snapshot
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.files.paths import default_objects_file, hand_configs_dir
from grasp_ctrl.trials.runs.manifest import settings_from_json

REACH = np.array([0.0, 0.0, 0.2])
ALLEGRO = hand_configs_dir() / "allegro_hand.toml"


@pytest.fixture(scope="module")
def allegro():  # type: ignore[no-untyped-def]
    return load_hand(ALLEGRO)


def test_each_hand_file_chooses_its_reading(hand, allegro) -> None:  # type: ignore[no-untyped-def]
    assert settings_for("paper", allegro).ramp_mode == "push_then_hold"
    assert settings_for("paper", hand).ramp_mode == "regulate"  # the LEAP's tables were tuned with it
    assert settings_for("paper").ramp_mode == "regulate"
    # an explicit override wins over the hand file's choice
    assert settings_for("paper", allegro, ramp_mode="regulate").ramp_mode == "regulate"
    # the hand file's table is the paper controller's only: grip_load keeps its own
    assert settings_for("grip_load", allegro) == settings_for("grip_load")


def _hand_with(tmp_path: Path, table: str) -> Path:
    text = ALLEGRO.read_text()
    start = text.index("[controllers.paper]")
    end = text.index("[arm]")
    path = tmp_path / "hand.toml"
    path.write_text(text[:start] + table + "\n\n" + text[end:])
    return path


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ('[controllers.paper]\nramp_mode = "push_harder"', "controllers.paper.ramp_mode"),
        ("[controllers.paper]\nramp_speed = 0.01", "controllers.paper.ramp_speed"),
        ("[controllers.paper]\nramp_max_speed_m_s = -1.0", "controllers.paper.ramp_max_speed_m_s"),
        ('[controllers.paper]\nstiffness_aware_squeeze = "yes"', "controllers.paper.stiffness_aware_squeeze"),
        ('[controllers.paper]\ncontroller = "grip_load"', "controllers.paper.controller"),
        ('[controllers.papr]\nramp_mode = "push_then_hold"', "controllers.papr"),
    ],
)
def test_a_wrong_choice_names_the_file_and_key(tmp_path: Path, table: str, key: str) -> None:
    hand = load_hand(_hand_with(tmp_path, table))  # the config layer keeps plain values
    with pytest.raises(ConfigError) as err:
        settings_for("paper", hand)
    assert err.value.key == key
    assert str(tmp_path / "hand.toml") in str(err.value)


def test_a_nested_value_is_refused_on_load(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"controllers\.paper\.ramp_mode"):
        load_hand(_hand_with(tmp_path, "[controllers.paper]\nramp_mode = [1, 2]"))


def test_run_json_keeps_the_reading() -> None:
    s = settings_for("paper", ramp_mode="push_then_hold")
    assert settings_from_json(flat_settings(s), "run.json") == s
    with pytest.raises(UsageError, match=r"settings\.ramp_mode: one of regulate, push_then_hold"):
        settings_from_json({"ramp_mode": "hold"}, "run.json")
    assert PaperSettings.check({"ramp_mode": "regulate"}, "x") == {"ramp_mode": "regulate"}


def test_grip_load_refuses_push_then_hold(allegro) -> None:  # type: ignore[no-untyped-def]
    obj = load_objects(default_objects_file(), allegro.name)["lego"]
    with pytest.raises(ConfigError, match="ramp_mode"):
        GripLoadController(allegro, obj, REACH, settings_for("grip_load", ramp_mode="push_then_hold"))


class Script:
    """Scripted snapshots for one controller; the palm arrives wherever it was sent."""

    def __init__(self, hand, obj, settings: PaperSettings) -> None:  # type: ignore[no-untyped-def]
        self.hand = hand
        self.ctrl = GraspController(hand, obj, REACH, settings)
        self.n = len(hand.fingers)
        self.t = 0.0
        self.palm = REACH + np.array([0.0, 0.0, 0.05])
        self.q = np.array([j.open_rad for j in hand.joints])
        self.grasping = np.array([f.grasp for f in hand.fingers])

    def tick(self, grips: list[float] | None = None) -> None:
        g = np.zeros(self.n)
        if grips is not None:
            g[self.grasping] = grips
        f_world = np.zeros((self.n, 3))
        f_world[:, 0] = g
        snap = Snapshot(
            t=self.t,
            q=self.q,
            p_palm_world=self.palm.copy(),
            tare_ready=True,
            in_contact=self.grasping.copy() if grips is not None else np.zeros(self.n, dtype=bool),
            f_sensor=np.zeros((self.n, 3)),
            f_hand=f_world,
            f_world=f_world,
            grip_n=g,
        )
        self.t += self.hand.dt
        cmd = self.ctrl.tick(snap)
        self.palm = cmd.p_palm_world.copy()
        self.q = cmd.q_goal.copy()  # ideal joints

    def to_ramp(self) -> None:
        for _ in range(3000):
            if self.ctrl.state == "ramp":
                return
            in_close = self.ctrl.state == "close"
            self.tick([0.5] * int(self.grasping.sum()) if in_close else None)
        raise AssertionError(self.ctrl.state)


@pytest.fixture
def chips_can(allegro):  # type: ignore[no-untyped-def]
    return load_objects(default_objects_file(), allegro.name)["chips_can"]


def test_push_then_hold_never_backs_a_pad_off_and_waits_for_every_pad(allegro, chips_can) -> None:  # type: ignore[no-untyped-def]
    s = Script(allegro, chips_can, settings_for("paper", allegro))
    s.to_ramp()
    k = int(s.grasping.sum())
    before = s.ctrl.motion.q_goal.copy()
    over = [3.5] + [1.0] * (k - 1)  # the index far above tau, the others short of it
    for _ in range(20):
        s.tick(over)
    index = s.ctrl.kin.slices["index"]
    assert np.allclose(s.ctrl.motion.q_goal[index], before[index])  # above tau: it stays where it is
    assert not np.allclose(s.ctrl.motion.q_goal, before)  # the others push forward
    assert s.ctrl.state == "ramp"
    tau = chips_can.tau_n
    settle_ticks = int(np.ceil(s.ctrl.s.ramp_settle_s / allegro.dt))
    for _ in range(settle_ticks + 2):
        s.tick([tau + 1.0] + [tau - 0.5 * s.ctrl.s.ramp_tolerance_n] * (k - 1))  # all reached, none backs off
    assert s.ctrl.state == "lift"


def test_push_then_hold_holds_the_goals_while_the_arm_lifts(allegro, chips_can) -> None:  # type: ignore[no-untyped-def]
    s = Script(allegro, chips_can, settings_for("paper", allegro))
    s.to_ramp()
    k = int(s.grasping.sum())
    tau = chips_can.tau_n
    while s.ctrl.state == "ramp":
        s.tick([tau] * k)
    held = s.ctrl.motion.q_goal.copy()
    z0 = s.palm[2]
    for _ in range(50):
        s.tick([tau * 0.6] * k)  # the grips fall as the object's weight comes on: no squeeze
    assert s.ctrl.state == "lift"
    assert np.array_equal(s.ctrl.motion.q_goal, held)
    assert s.palm[2] > z0 + 0.01


def test_regulate_squeezes_in_lift(allegro, chips_can) -> None:  # type: ignore[no-untyped-def]
    s = Script(allegro, chips_can, settings_for("paper"))
    s.to_ramp()
    k = int(s.grasping.sum())
    tau = chips_can.tau_n
    for _ in range(2000):
        if s.ctrl.state != "ramp":
            break
        s.tick([tau] * k)
    assert s.ctrl.state == "lift"
    held = s.ctrl.motion.q_goal.copy()
    for _ in range(10):
        s.tick([tau * 0.6] * k)
    assert not np.array_equal(s.ctrl.motion.q_goal, held)  # the grips are regulated toward tau


def test_the_allegros_tables_stay_the_allegros(allegro) -> None:  # type: ignore[no-untyped-def]
    allegro_objects = load_objects(default_objects_file(), allegro.name)
    leap_objects = load_objects(default_objects_file(), "leap_hand")
    assert allegro_objects["cleanser"].tau_n == allegro_objects["mustard_bottle"].tau_n == 3.0
    assert allegro_objects["cleanser"].grip_targets is None  # the LEAP's force-closure targets stay the LEAP's
    assert (leap_objects["cleanser"].tau_n, leap_objects["mustard_bottle"].tau_n) == (2.5, 3.0)
    for name in ("chips_can", "lego", "plastic_bottle", "paper_cup"):
        assert allegro_objects[name].tau_n == 2.0  # the paper's tau
