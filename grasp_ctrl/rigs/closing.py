"""Closing a trial's parts (hand, arm, sensors): every one, even when one fails."""

from __future__ import annotations

from typing import Any


def close_all(*parts: Any, raise_error: bool = True) -> None:
    """Close every part in order even when one fails; the first error is raised after (if asked)."""
    error: BaseException | None = None
    for part in parts:
        try:
            part.close()
        except Exception as exc:  # noqa: BLE001 - keep closing the rest
            error = error or exc
    if error is not None and raise_error:
        raise error
