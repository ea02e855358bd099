"""One-line progress for long commands (run, tune, bench, train, evaluate), with tqdm.

Shown only on a terminal (stderr) and never with ``--quiet``: a redirected or
piped run writes no progress at all, so logs and captured output hold results
only. ``status_line`` is for work reported as text (training epochs): the line
is rewritten in place.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable
from typing import Any, TextIO, TypeVar

from tqdm import tqdm

T = TypeVar("T")


def shown(enabled: bool = True, stream: TextIO | None = None) -> bool:
    stream = stream or sys.stderr
    try:
        return bool(enabled) and stream.isatty()
    except (AttributeError, ValueError):  # a closed or odd stream
        return False


def progress_bar(
    total: int | None,
    desc: str,
    enabled: bool = True,
    stream: TextIO | None = None,
    unit: str = "it",
    every_update: bool = False,
) -> tqdm:
    """A tqdm bar on stderr (disabled unless ``shown``); use as a context manager.
    ``every_update``: redraw on every update (for slow items such as trials)."""
    stream = stream or sys.stderr
    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        file=stream,
        disable=not shown(enabled, stream),
        dynamic_ncols=True,
        leave=False,
        smoothing=0.1,
        mininterval=0.0 if every_update else 0.1,
    )


def track(
    items: Iterable[T],
    desc: str,
    enabled: bool = True,
    total: int | None = None,
    unit: str = "it",
    stream: TextIO | None = None,
) -> Iterable[T]:
    """``items`` with a progress bar over them."""
    stream = stream or sys.stderr
    return tqdm(
        items,
        desc=desc,
        total=total,
        unit=unit,
        file=stream,
        disable=not shown(enabled, stream),
        dynamic_ncols=True,
        leave=False,
    )


class StatusLine:
    """A one-line status rewritten in place (``update(text)``); ``note(text)`` prints a
    line that stays (results), above the status. Off unless ``shown``; notes are
    printed to stdout either way unless ``quiet_notes``."""

    def __init__(self, enabled: bool = True, stream: TextIO | None = None, quiet_notes: bool = False) -> None:
        self.stream = stream or sys.stderr
        self.on = shown(enabled, self.stream)
        self.quiet_notes = quiet_notes
        self._bar: Any = (
            tqdm(total=None, bar_format="{desc}", file=self.stream, dynamic_ncols=True, leave=False)
            if self.on
            else None
        )

    def update(self, text: str) -> None:
        if self._bar is not None:
            self._bar.set_description_str(text)

    def note(self, text: str) -> None:
        if self.quiet_notes:
            return
        if self._bar is not None:
            self._bar.clear()
        print(text, flush=True)
        if self._bar is not None:
            self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> StatusLine:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


def status_callback(line: StatusLine) -> Callable[[str], None]:
    """A ``progress(str)`` callback for the learning code: every message becomes the status."""
    return line.update
