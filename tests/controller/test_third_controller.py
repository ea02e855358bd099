"""Adding a controller is one module and one line in the registry (controller/registry.py): this
module is such a module, a controller that waits between ramp and lift with its own settings
class, and the test adds the line, then builds it, ticks it through its new state and draws it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.controller import diagram, registry
from grasp_ctrl.controller.machine import STATES, TRANSITIONS, GraspController
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.snapshot import Snapshot


@dataclass(frozen=True)
class WaitSettings(PaperSettings):
    controller: ClassVar[str] = "wait"
    wait_s: float = 0.5  # how long the grasp rests between ramp and lift


class WaitController(GraspController):
    """The paper's controller with a wait state between ramp and lift."""

    SETTINGS: ClassVar[type[PaperSettings]] = WaitSettings
    s: WaitSettings
    STATES = [*STATES[:4], "wait", *STATES[4:]]
    TRANSITIONS = [t for t in TRANSITIONS if t[:2] != ("ramp", "lift")] + [
        ("ramp", "wait", "ramp_settled", None),
        ("wait", "lift", "waited", None),
    ]

    def waited(self) -> bool:
        return self._elapsed() >= self.s.wait_s

    @classmethod
    def guard_words(cls, s: PaperSettings) -> dict[str, str]:
        assert isinstance(s, WaitSettings)
        return {**super().guard_words(s), "waited": f"{s.wait_s:g} s in wait"}


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(registry.CONTROLLERS, "wait", f"{__name__}:WaitController")  # the one line


def _tick(ctrl: GraspController, hand, t: float, palm: np.ndarray, q: np.ndarray, grips: list[float] | None):  # type: ignore[no-untyped-def]
    n = len(hand.fingers)
    grasping = np.array([f.grasp for f in hand.fingers])
    g = np.zeros(n)
    if grips is not None:
        g[grasping] = grips
    snap = Snapshot(
        t=t,
        q=q,
        p_palm_world=palm,
        tare_ready=True,
        in_contact=grasping.copy() if grips is not None else np.zeros(n, dtype=bool),
        f_sensor=np.zeros((n, 3)),
        f_hand=np.zeros((n, 3)),
        f_world=np.zeros((n, 3)),
        grip_n=g,
    )
    return ctrl.tick(snap)


def test_a_third_controller_is_one_module_and_one_registry_line(registered, hand, objects, capsys) -> None:  # type: ignore[no-untyped-def]
    assert registry.controller_names()[-1] == "wait"
    settings = registry.settings_for("wait", wait_s=0.2)
    assert isinstance(settings, WaitSettings) and settings.open_s == PaperSettings().open_s
    reach = np.array([0.0, 0.0, 0.2])
    ctrl = registry.make_controller(hand, objects["chips_can"], reach, settings)
    assert type(ctrl) is WaitController

    # ticked: through close and ramp (every grip on its target) into wait, and on to lift
    palm, q, t = reach + np.array([0.0, 0.0, 0.05]), np.array([j.open_rad for j in hand.joints]), 0.0
    seen: list[str] = []
    for _ in range(3000):
        state = ctrl.state
        if not seen or seen[-1] != state:
            seen.append(state)
        if state == "lift":
            break
        grips = ctrl.grip_targets[ctrl.grasp_mask].tolist() if state in ("close", "ramp", "wait") else None
        cmd = _tick(ctrl, hand, t, palm, q, grips)
        palm, q, t = cmd.p_palm_world.copy(), cmd.q_goal.copy(), t + hand.dt
    assert seen == ["tare", "reach", "close", "ramp", "wait", "lift"]
    assert ctrl.history[-1][0] - ctrl.history[-2][0] == pytest.approx(0.2, abs=2 * hand.dt)  # waited 0.2 s

    # its settings in the flat table of run.json and the records, and back
    table = registry.flat_settings(settings)
    assert (table["controller"], table["wait_s"], list(table)[-1]) == ("wait", 0.2, "wait_s")
    assert registry.settings_from_flat(table, "run.json") == settings
    assert registry.flat_settings(registry.settings_for("paper"))["wait_s"] == 0.5  # a key every record has

    # drawn, in its guard's words, by the library and the command
    text = diagram.mermaid(settings)
    assert "  ramp --> wait: ramp_settled (" in text
    assert "  wait --> lift: waited (0.2 s in wait)" in text
    assert main(["diagram", "--controller", "wait"]) == 0
    assert "  wait --> lift: waited (0.5 s in wait)" in capsys.readouterr().out


def test_a_registry_line_must_name_the_settings_controller(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(registry.CONTROLLERS, "pause", f"{__name__}:WaitController")
    with pytest.raises(TypeError, match="'wait', not 'pause'"):
        registry.settings_for("pause")
