"""Exception types shared across the package.

Each carries a stable snake_case ``reason`` where it can end a trial, so the
trial runner can report it in the run summary (docs/design.md 5.2).
"""

from __future__ import annotations


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


#: The SIGINT / SIGTERM numbers the command line's handlers received during this command
#: (cli/__init__.py). An interrupt inside an extension module's import can surface as an
#: ImportError, which an optional import (numba, say) would take for a missing package and go on.
SIGNALLED: list[int] = []


def reraise_interrupt() -> None:
    """Raise the interrupt a handler noted, if any (``Terminated`` for SIGTERM): called where an
    ``except ImportError`` would otherwise swallow it."""
    if SIGNALLED:
        import signal

        raise Terminated() if SIGNALLED[-1] == signal.SIGTERM else KeyboardInterrupt()
