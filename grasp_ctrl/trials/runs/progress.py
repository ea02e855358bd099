"""Progress of a series of trials: one line on a terminal (a tqdm bar with the
running tally and the last outcome), nothing when stderr is not a terminal or
with ``--quiet``."""

from __future__ import annotations

import sys
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any, TextIO

from grasp_ctrl.display.progress_bar import progress_bar


def format_duration(seconds: float) -> str:
    s = int(round(max(seconds, 0.0)))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


class Progress:
    """``trial_done(record)`` per finished trial; ``close()`` when the series ends."""

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        enabled: bool = True,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.total = total
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.clock = clock
        self.done = 0
        self._tally: dict[str, list[int]] = defaultdict(lambda: [0, 0])  # policy -> [successes, trials]
        self._bar = progress_bar(total, "trials", enabled, self.stream, unit="trial", every_update=True)

    def resumed(self, records: list[dict[str, Any]]) -> None:
        """Trials already on disk from an earlier, interrupted session (said once, also off a terminal)."""
        for rec in records:
            self._count(rec)
        self.done = len(records)
        self._bar.update(self.done)
        if records and self.enabled:
            self._bar.write(f"resuming: {self.done} of {self.total} trials already recorded", file=self.stream)

    def _count(self, rec: dict[str, Any]) -> None:
        t = self._tally[rec["policy"]]
        t[0] += bool(rec["success"])
        t[1] += 1

    def status(self, rec: dict[str, Any]) -> str:
        """The tally and the last outcome, e.g. ``linear_mock 11/12 ok; last: paper_cup #1 FAIL knocked_over``."""
        tally = ", ".join(f"{p} {s}/{n} ok" for p, (s, n) in self._tally.items())
        mark = "ok" if rec["success"] else f"FAIL {rec['reason']}"
        return f"{tally}; last: {rec['object']} #{rec['trial']} {mark}"

    def trial_done(self, rec: dict[str, Any]) -> None:
        self._count(rec)
        self.done += 1
        self._bar.set_postfix_str(self.status(rec), refresh=False)
        self._bar.update(1)

    def close(self) -> None:
        self._bar.close()
