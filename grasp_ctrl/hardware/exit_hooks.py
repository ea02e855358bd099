"""The real hands' exit hooks: their safe stop also runs at interpreter exit and on SIGTERM.

SIGTERM would end the process without unwinding; turned into SystemExit, ``with`` blocks and
``finally`` clauses run the safe stop (SIGINT already raises KeyboardInterrupt). One rule for every
hand backend that drives hardware (the Dynamixel hand, the Allegro on CAN).
"""

from __future__ import annotations

import atexit
import signal
import threading
from collections.abc import Callable
from typing import Any


def _sigterm_to_exit(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


class ExitHooks:
    """``close`` registered with atexit, and SIGTERM made SystemExit while installed (only from
    the main thread and only where nobody handles SIGTERM yet; the old handler comes back)."""

    def __init__(self, close: Callable[[], None]) -> None:
        self._close = close
        self._atexit_registered = False
        self._old_sigterm: Any = None

    def install(self, handle_signals: bool) -> None:
        if not self._atexit_registered:
            atexit.register(self._close)
            self._atexit_registered = True
        if handle_signals and threading.current_thread() is threading.main_thread():
            if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, None):
                self._old_sigterm = signal.signal(signal.SIGTERM, _sigterm_to_exit)

    def remove(self) -> None:
        if self._atexit_registered:
            atexit.unregister(self._close)
            self._atexit_registered = False
        if self._old_sigterm is not None and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, self._old_sigterm)
            self._old_sigterm = None
