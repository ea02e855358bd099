"""Operator labels for trials on real hardware, where no ground truth exists.

After each trial the operator is shown what the controller itself observed and
answers at a prompt: success, or a failure reason, plus an optional note.
Input and output are plain text streams so tests (and scripted sessions) can
feed the answers: ``OperatorLabeller(io.StringIO("s\\n\\n"), io.StringIO())``.
The record keeps the label as the outcome and the controller's view beside it.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, TextIO

from grasp_ctrl.errors import GraspCtrlError

# Offered by number at the prompt; any other snake_case word is accepted too.
FAILURE_REASONS = (
    "slipped",
    "dropped_early",
    "crushed",
    "knocked_over",
    "no_contact",
    "ramp_timeout",
    "no_release",
    "not_released",
    "overforce",
    "sensor_stale",
    "hardware_error",
    "aborted",
)
_WORD = re.compile(r"^[a-z][a-z0-9_]*$")


class OperatorQuit(GraspCtrlError):
    """The operator stopped the run at the prompt (or the input ended)."""

    exit_status = 130


@dataclass(frozen=True)
class Label:
    success: bool
    reason: str | None
    note: str = ""


class OperatorLabeller:
    def __init__(self, stdin: TextIO | None = None, stdout: TextIO | None = None) -> None:
        self.stdin = stdin or sys.stdin
        self.stdout = stdout or sys.stderr

    def _ask(self, prompt: str) -> str:
        self.stdout.write(prompt)
        self.stdout.flush()
        line = self.stdin.readline()
        if not line:
            raise OperatorQuit(
                "operator input ended; the trials labelled so far are saved (continue with run --resume)"
            )
        return line.strip()

    def describe(self, title: str, observed: Mapping[str, Any]) -> None:
        view = observed.get("controller", {})
        said = "success" if view.get("success") else f"failure ({view.get('reason') or 'no reason'})"
        lines = [f"--- {title}", f"controller: ended in {view.get('final_state', '?')}, says {said}"]
        if "peak_grip_est_n" in observed:
            lines.append(f"peak estimated grip: {observed['peak_grip_est_n']:.2f} N")
        self.stdout.write("\n".join(lines) + "\n")

    def label(self, title: str, observed: Mapping[str, Any]) -> Label:
        """Show the controller's view and ask; Enter accepts the controller's verdict."""
        self.describe(title, observed)
        view = observed.get("controller", {})
        default_ok = bool(view.get("success"))
        while True:
            ans = self._ask(f"outcome? [s]uccess / [f]ailure / [q]uit (Enter: {'s' if default_ok else 'f'}): ").lower()
            if ans == "":
                ans = "s" if default_ok else "f"
            if ans in ("q", "quit"):
                raise OperatorQuit(
                    "stopped by the operator; the trials labelled so far are saved (continue with run --resume)"
                )
            if ans in ("s", "success", "f", "failure", "fail"):
                break
            self.stdout.write("please answer s, f or q\n")
        reason = None
        if ans.startswith("f"):
            reason = self._ask_reason(view.get("reason") if isinstance(view.get("reason"), str) else None)
        note = self._ask("note (Enter: none): ")
        return Label(success=reason is None, reason=reason, note=note)

    def _ask_reason(self, default: str | None) -> str:
        menu = "  ".join(f"{i}) {r}" for i, r in enumerate(FAILURE_REASONS, 1))
        self.stdout.write(f"failure reasons: {menu}\n")
        hint = f" (Enter: {default})" if default else ""
        while True:
            ans = self._ask(f"reason? number or word{hint}: ").lower()
            if ans == "" and default:
                return default
            if ans.isdigit() and 1 <= int(ans) <= len(FAILURE_REASONS):
                return FAILURE_REASONS[int(ans) - 1]
            if _WORD.match(ans):
                return ans
            self.stdout.write(f"give a number 1-{len(FAILURE_REASONS)} or a snake_case word\n")


def apply_label(record: dict[str, Any], label: Label) -> dict[str, Any]:
    """The operator's label becomes the outcome; the controller's view stays beside it."""
    out = dict(record)
    out["success"] = label.success
    out["reason"] = label.reason
    out["note"] = label.note
    out["judged_by"] = "operator"
    return out


def labelled(run_trial: Callable[..., dict[str, Any]], labeller: OperatorLabeller) -> Callable[..., dict[str, Any]]:
    """Wrap a hardware trial function (same signature as runner.TrialFn) with the prompt."""

    def run(policy: str, obj: Any, trial: int, seed: int, log_path: Any) -> dict[str, Any]:
        record = run_trial(policy, obj, trial, seed, log_path)
        title = f"{policy} / {obj.name} / trial {trial}"
        return apply_label(record, labeller.label(title, record))

    return run
