"""``diagram --controller NAME`` draws the state machine of any registered controller from its own
table: grip_load's preshape and load states, and a third controller's new edge in its guard's words."""

from __future__ import annotations

import pytest

from grasp_ctrl.cli import main
from grasp_ctrl.controller import diagram
from grasp_ctrl.controller.grip_load import LOAD_TRANSITIONS
from grasp_ctrl.controller.machine import STATES, TRANSITIONS, GraspController
from grasp_ctrl.controller.registry import settings_for


def test_grip_load_is_drawn_with_its_load_phase(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diagram", "--controller", "grip_load"]) == 0
    lines = [ln.strip() for ln in capsys.readouterr().out.splitlines()]
    for src, dst, guard, reason in LOAD_TRANSITIONS:
        match = [ln for ln in lines if ln.startswith(f"{src} --> {dst}: {guard} (")]
        assert len(match) == 1, (src, dst, guard)
        assert match[0].endswith(f"→ {reason}") if reason else "→" not in match[0]
    assert "preshape --> fault: close_timed_out" in "\n".join(lines)


def test_the_hand_files_reading_is_in_the_words(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diagram", "--hand", "hand_configs/allegro_hand.toml"]) == 0
    assert "ramp_settled (every grip at tau or above" in capsys.readouterr().out
    assert main(["diagram"]) == 0
    assert "ramp_settled (grips averaged over" in capsys.readouterr().out


class _Waiting(GraspController):
    """A third controller: the paper's, with a wait state between ramp and lift."""

    STATES = [*STATES[:4], "wait", *STATES[4:]]
    TRANSITIONS = [t for t in TRANSITIONS if t[:2] != ("ramp", "lift")] + [
        ("ramp", "wait", "ramp_settled", None),
        ("wait", "lift", "waited", None),
    ]

    def waited(self) -> bool:
        """Half a second in wait."""
        return self._elapsed() >= 0.5


def test_a_third_controller_is_drawn_from_its_table(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(diagram, "controller_class", lambda name: _Waiting)
    text = diagram.mermaid(settings_for("paper"))
    assert "  ramp --> wait: ramp_settled (" in text
    assert "  wait --> lift: waited (Half a second in wait)" in text
    assert "  wait --> fault: runtime fault" in text  # a state without a fault edge of its own
    pytest.importorskip("matplotlib")
    assert diagram.draw(tmp_path / "wait.png", settings_for("paper")).stat().st_size > 10_000
