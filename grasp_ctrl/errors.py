"""Exception types shared across the package.

Each carries a stable snake_case ``reason`` where it can end a trial, so the
trial runner can report it in the run summary (docs/design.md 5.2).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any


class GraspCtrlError(Exception):
    """Base class for errors the command line reports as one line."""

    exit_status = 1


class ConfigError(GraspCtrlError):
    """A configuration file is missing, unreadable or invalid."""

    exit_status = 2

    def __init__(self, path: str, key: str, expected: str) -> None:
        self.path = str(path)
        self.key = key
        self.expected = expected
        super().__init__(f"{self.path}: {key}: {expected}")

    def __reduce__(self) -> tuple[type[ConfigError], tuple[str, str, str]]:
        # Raised in a trial worker process, it must cross back intact: the default
        # pickling calls __init__ with the message alone and breaks the process pool.
        return (type(self), (self.path, self.key, self.expected))


class UsageError(GraspCtrlError):
    """Bad command-line input that argparse cannot catch by itself."""

    exit_status = 2


class PolicyError(GraspCtrlError):
    """A force-estimator policy cannot be found, loaded or does not fit the sensors."""

    exit_status = 2


class FrameError(GraspCtrlError, ValueError):
    """A raw tactile frame is malformed (length, range, NaN)."""


class HardwareError(GraspCtrlError):
    """The hand, arm or a sensor failed; ends a trial with ``reason``."""

    def __init__(self, message: str, reason: str = "hardware_error") -> None:
        self.reason = reason
        super().__init__(message)

    def __reduce__(self) -> tuple[type[HardwareError], tuple[str, ...]]:
        return (HardwareError, (str(self), self.reason)) if type(self) is HardwareError else (type(self), (str(self),))


class SensorStaleError(HardwareError):
    """A fingertip delivered no valid frame for longer than ``stale_after_s``."""

    def __init__(self, message: str) -> None:
        super().__init__(message, reason="sensor_stale")


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread: the command stops as on Ctrl-C (the hand stops
    safely, finished trials stay recorded, the run stays resumable) and exits with 143."""

    exit_status = 143


def interrupt_detail(exc: BaseException) -> str:
    """How a trial's record names the interrupt that ended it (``fault_detail``)."""
    return "terminated (SIGTERM)" if isinstance(exc, Terminated) else "operator abort (Ctrl-C)"


#: The SIGINT / SIGTERM numbers the command line's handlers received during this command
#: (cli/__init__.py). An interrupt inside an extension module's import can surface as an
#: ImportError, which an optional import (numba, say) would take for a missing package and go on.
SIGNALLED: list[int] = []


def reraise_interrupt() -> None:
    """Raise the interrupt a handler noted, if any (``Terminated`` for SIGTERM): called where an
    ``except ImportError`` would otherwise swallow it."""
    if SIGNALLED:
        raise Terminated() if SIGNALLED[-1] == signal.SIGTERM else KeyboardInterrupt()


@contextlib.contextmanager
def interrupts_held(reraise: bool = True) -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends (main thread only; elsewhere a no-op), then
    raise the first as usual (``reraise``) or only note it in ``SIGNALLED``. A signal mask
    would not do: any thread may take the signal, and Python runs the handler in the main thread
    wherever it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: object) -> None:
        held.append(signum)

    old_int = signal.signal(signal.SIGINT, hold)
    try:
        old_term = signal.signal(signal.SIGTERM, hold)
    except BaseException:
        signal.signal(signal.SIGINT, _handler(old_int))
        raise
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, _handler(old_int))
        signal.signal(signal.SIGTERM, _handler(old_term))
        if held and reraise:
            signal.raise_signal(held[0])
        elif held:
            SIGNALLED.extend(held)


def _handler(old: Any) -> Any:
    return signal.SIG_DFL if old is None else old  # None: a handler not set from Python
