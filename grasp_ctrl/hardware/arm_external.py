"""External arm mode: another system moves the palm; this program asks and waits.

Every time the commanded palm position has moved ``confirm_step_m`` away from
the last confirmed one (or the command has come to rest somewhere else), the
arm prints the requested position and blocks until the operator (or a script
on stdin) confirms:
  Enter        reached the requested position
  "x y z"      reached this position instead (m, world frame)
  "abort"      stop the trial (HardwareError, reason "aborted")
``ask`` is injectable (tests pass a scripted function); the default is ``input``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.errors import HardwareError
from grasp_ctrl.numeric.limits import clamped_palm_target


class ExternalArm:
    def __init__(
        self,
        hand: HandConfig,
        ask: Callable[[str], str] | None = None,
        start_world: np.ndarray | None = None,
    ) -> None:
        self.cfg = hand.arm
        self.ask = ask or input
        self.confirmed = np.array(start_world if start_world is not None else (0.0, 0.0, hand.arm.z_max_m), dtype=float)
        self.last_command: np.ndarray | None = None
        self.prompts = 0

    def _prompt(self, text: str) -> str:
        self.prompts += 1
        try:
            return self.ask(text).strip()
        except EOFError:
            raise HardwareError("external arm: no confirmation (input closed)", reason="aborted") from None

    def _parse(self, answer: str, requested: np.ndarray) -> np.ndarray:
        if answer.lower() in ("abort", "a", "q", "quit"):
            raise HardwareError("external arm: aborted by the operator", reason="aborted")
        if not answer or answer.lower() in ("y", "yes", "ok"):
            return requested
        try:
            values = [float(v) for v in answer.replace(",", " ").split()]
        except ValueError:
            values = []
        if len(values) != 3 or not np.all(np.isfinite(values)):
            raise HardwareError(f"external arm: expected Enter, 'x y z' or 'abort', got {answer!r}", reason="aborted")
        return np.array(values)

    def connect(self) -> None:
        p = self.confirmed
        answer = self._prompt(
            f"external arm: palm at x y z = {p[0]:.3f} {p[1]:.3f} {p[2]:.3f} m? [Enter = yes, 'x y z' = actual, 'abort'] "
        )
        self.confirmed = self._parse(answer, p)

    def command(self, p_world: np.ndarray) -> None:
        p = clamped_palm_target(p_world, self.cfg.z_min_m, self.cfg.z_max_m)
        resting = self.last_command is not None and np.allclose(p, self.last_command, atol=1e-9)
        self.last_command = p
        far = np.linalg.norm(p - self.confirmed)
        if far >= self.cfg.confirm_step_m or (resting and far > self.cfg.tolerance_m):
            answer = self._prompt(
                f"external arm: move the palm to x y z = {p[0]:.3f} {p[1]:.3f} {p[2]:.3f} m "
                f"(dz = {p[2] - self.confirmed[2]:+.3f}) and confirm [Enter / 'x y z' / 'abort'] "
            )
            self.confirmed = self._parse(answer, p)

    def position(self) -> np.ndarray:
        return self.confirmed.copy()

    def stop(self) -> None:
        self.last_command = self.confirmed.copy()

    def close(self) -> None:
        self.stop()
