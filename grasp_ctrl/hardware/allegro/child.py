"""Child processes of the Allegro's CAN backend (the PD loop's, pd_process.py; the emulated hand's,
emulators/allegro_can_process.py) and what they share with the command's process.

- ``SharedBlock``: named float64 fields and text fields over one shared mapping (an unlinked
  temporary file, handed to the child by descriptor). Latest-value exchange without locks: a
  writer brackets a multi-field update with a sequence counter (``write_seq``: odd while it
  writes), a reader copies and retries when the counter moved (``read_seq``).
- ``start_child``: ``python -c`` running ``module:function(payload)``. SIGINT and SIGTERM are
  blocked while it starts and ignored from its first line: a terminal sends Ctrl-C to the whole
  process group, and the command, not the child, decides how the hand stops. The start itself
  holds the command's interrupts, so no child is started without its handle.
- ``Child``: the handle; ``stop`` waits for the child to end (it was asked), kills it after a
  timeout, and always reaps it.
- ``SocketLink``: a ``CanLink`` over one end of a Unix socket pair (sequenced packets: frames keep
  their boundaries, and what was sent before the other end closed is still delivered), the bus
  between two processes (python-can's virtual bus lives in one process). A full queue or a closed
  other end is a failed send or receive, as a bus-off is on a wire.
"""

from __future__ import annotations

import mmap
import os
import pickle
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from grasp_ctrl.errors import HardwareError, interrupts_held
from grasp_ctrl.hardware.allegro.protocol import CanFrame

_SIGNALS = {signal.SIGINT, signal.SIGTERM}
# The child's first line: Ctrl-C and SIGTERM ignored (they were blocked since the fork), then the
# command's import path, then the target with its payload (both pickled on stdin).
_BOOT = (
    "import signal as s;s.signal(s.SIGINT,s.SIG_IGN);s.signal(s.SIGTERM,s.SIG_IGN);"
    "s.pthread_sigmask(s.SIG_UNBLOCK,{s.SIGINT,s.SIGTERM});"
    "import pickle,sys;i=sys.stdin.buffer;sys.path[:0]=pickle.load(i);"
    "import importlib;m,f=sys.argv[1].split(':');getattr(importlib.import_module(m),f)(pickle.load(i))"
)


def processes_supported() -> bool:
    """Whether the backend's children can run here (POSIX: descriptors passed, signal masks)."""
    return os.name == "posix" and hasattr(signal, "pthread_sigmask")


# ---- shared memory -------------------------------------------------------------------------------
class Layout:
    """Field names and sizes: ``floats`` (float64 each) and ``texts`` (bytes, UTF-8)."""

    def __init__(self, floats: dict[str, int], texts: dict[str, int]) -> None:
        self.floats = dict(floats)
        self.texts = dict(texts)
        self.n_floats = sum(self.floats.values())
        self.size = 8 * self.n_floats + sum(self.texts.values())


class SharedBlock:
    """A ``Layout`` over one shared mapping; ``fd`` None: a new one (this process owns it)."""

    def __init__(self, layout: Layout, fd: int | None = None) -> None:
        self.layout = layout
        if fd is None:
            f = tempfile.TemporaryFile()
            fd = os.dup(f.fileno())
            f.close()
            os.ftruncate(fd, layout.size)
        self.fd = fd
        self._mm = mmap.mmap(fd, layout.size)
        values = np.frombuffer(self._mm, dtype=np.float64, count=layout.n_floats)
        self.f: dict[str, np.ndarray] = {}
        at = 0
        for name, n in layout.floats.items():
            self.f[name] = values[at : at + n]
            at += n
        self._texts: dict[str, tuple[int, int]] = {}
        offset = 8 * layout.n_floats
        for name, n in layout.texts.items():
            self._texts[name] = (offset, n)
            offset += n

    def __getitem__(self, name: str) -> float:
        return float(self.f[name][0])

    def __setitem__(self, name: str, value: float) -> None:
        self.f[name][0] = value

    def set_text(self, name: str, text: str) -> None:
        at, n = self._texts[name]
        raw = text.encode("utf-8", "replace")[: n - 1]
        self._mm[at : at + n] = raw + bytes(n - len(raw))

    def text(self, name: str) -> str:
        at, n = self._texts[name]
        return bytes(self._mm[at : at + n]).split(b"\0", 1)[0].decode("utf-8", "replace")

    def write_seq(self, seq: str, fields: dict[str, Any]) -> None:
        """Write ``fields`` between two steps of the counter ``seq`` (odd meanwhile)."""
        s = self.f[seq]
        s[0] += 1.0
        for name, value in fields.items():
            self.f[name][:] = value
        s[0] += 1.0

    def read_seq(self, seq: str, names: Sequence[str], tries: int = 100) -> tuple[float, list[np.ndarray]] | None:
        """Copies of ``names`` consistent with one value of ``seq`` (and that value), or None
        when the writer kept writing."""
        s = self.f[seq]
        for _ in range(tries):
            before = s[0]
            if before % 2.0:
                continue
            out = [self.f[n].copy() for n in names]
            if s[0] == before:
                return float(before), out
        return None

    def release_fd(self) -> None:
        """Close the descriptor (once a child has its own copy); the mapping stays."""
        fd, self.fd = self.fd, -1
        if fd >= 0:
            os.close(fd)


# ---- the child process ---------------------------------------------------------------------------
class Child:
    """A started child process, always reaped by ``stop``."""

    def __init__(self, proc: subprocess.Popen[bytes], name: str) -> None:
        self.proc = proc
        self.name = name

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    @property
    def returncode(self) -> int | None:
        return self.proc.poll()

    def wait_ready(self, block: SharedBlock, timeout_s: float) -> float:
        """Wait while ``block["ready"]`` is 0, the child lives and ``timeout_s`` has not passed;
        the flag's value then (the child sets it: 1 ready, -1 failed)."""
        end = time.monotonic() + timeout_s
        while block["ready"] == 0.0 and self.alive and time.monotonic() < end:
            time.sleep(0.002)
        return block["ready"]

    def stop(self, timeout_s: float) -> int:
        """Wait up to ``timeout_s`` for it to end (it was asked to), then kill it; reaped either
        way, a second interrupt meanwhile held until then."""
        with interrupts_held():
            try:
                return self.proc.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                return self.proc.wait()


def start_child(target: str, payload: object, pass_fds: Sequence[int] = (), name: str = "") -> Child:
    """Run ``target`` (``"module:function"``) with ``payload`` in a new Python process that
    ignores SIGINT and SIGTERM from its first instruction; ``pass_fds`` stay open in it."""
    with interrupts_held():
        old = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
        try:
            proc = subprocess.Popen(
                [sys.executable, "-c", _BOOT, target], stdin=subprocess.PIPE, pass_fds=tuple(pass_fds), close_fds=True
            )
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        child = Child(proc, name or target)
        try:
            assert proc.stdin is not None
            pickle.dump([p for p in sys.path if isinstance(p, str)], proc.stdin)
            pickle.dump(payload, proc.stdin)
            proc.stdin.close()
        except BaseException as exc:
            child.stop(0.0)
            if isinstance(exc, OSError):
                raise HardwareError(f"{child.name}: the process did not start: {exc}") from None
            raise
    return child


def parent_alive(parent_pid: int) -> bool:
    """In a child: whether the process that started it still runs (a dead parent's children are
    handed to another)."""
    return os.getppid() == parent_pid


# ---- a CAN bus between two processes -------------------------------------------------------------
_FRAME = struct.Struct("<IBB8s")  # id, flags, length, data
_REMOTE, _EXTENDED, _ERROR = 1, 2, 4
SEND_WAIT_S = 0.01  # as PythonCanLink's send timeout


def socket_pair() -> tuple[socket.socket, socket.socket]:
    """Two connected ends of a Unix socket (each for one process): sequenced packets, or
    datagrams where there are none (a datagram socket's queue is dropped when its other end
    closes)."""
    seqpacket = getattr(socket, "SOCK_SEQPACKET", None)
    if seqpacket is not None:
        try:
            return socket.socketpair(socket.AF_UNIX, seqpacket)
        except OSError:
            pass
    return socket.socketpair(socket.AF_UNIX, socket.SOCK_DGRAM)


class SocketLink:
    """A ``CanLink`` over one end of ``socket_pair``."""

    def __init__(self, sock: socket.socket, name: str) -> None:
        self.sock = sock
        self.sock.setblocking(False)
        self.name = name
        self.closed = False
        self.ended = False  # the other end closed

    @classmethod
    def from_fd(cls, fd: int, name: str) -> SocketLink:
        return cls(socket.socket(fileno=fd), name)

    def fileno(self) -> int:
        return self.sock.fileno()

    def send(self, frame: CanFrame) -> None:
        flags = (_REMOTE if frame.is_remote else 0) | (_EXTENDED if frame.is_extended else 0)
        flags |= _ERROR if frame.is_error else 0
        raw = _FRAME.pack(frame.arbitration_id, flags, len(frame.data), bytes(frame.data))
        try:
            try:
                self.sock.send(raw)
            except BlockingIOError:  # the queue is full: wait as a controller's transmit buffer would
                if not select.select([], [self.sock], [], SEND_WAIT_S)[1]:
                    raise OSError("the bus's queue stays full") from None
                self.sock.send(raw)
        except OSError as exc:
            raise HardwareError(f"CAN bus {self.name}: send failed: {exc}", reason="hardware_error") from None

    def recv(self, timeout_s: float) -> CanFrame | None:
        if self.ended:  # (said once; from then on a quiet bus, not a busy loop)
            time.sleep(max(0.0, timeout_s))
            return None
        try:
            try:
                raw = self.sock.recv(64)
            except BlockingIOError:
                if timeout_s <= 0 or not select.select([self.sock], [], [], timeout_s)[0]:
                    return None
                raw = self.sock.recv(64)
        except BlockingIOError:
            return None
        except OSError as exc:
            raise HardwareError(f"CAN bus {self.name}: receive failed: {exc}", reason="hardware_error") from None
        if not raw:
            self.ended = True
            raise HardwareError(f"CAN bus {self.name}: the other end has closed", reason="hardware_error")
        if len(raw) != _FRAME.size:
            raise HardwareError(
                f"CAN bus {self.name}: a packet of {len(raw)} bytes is no frame", reason="hardware_error"
            )
        arb, flags, n, data = _FRAME.unpack(raw)
        return CanFrame(
            arbitration_id=arb,
            data=data[: min(n, 8)],
            is_remote=bool(flags & _REMOTE),
            is_extended=bool(flags & _EXTENDED),
            is_error=bool(flags & _ERROR),
            timestamp=time.monotonic(),
        )

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.sock.close()
