"""Outputs a user names: only a regular file or a new path is ever replaced; a character
device, a FIFO, a link to one of them and this process's own descriptors are written as
streams; ``-`` is standard output; a folder output refuses them all.

Every device node, FIFO and link lives in the test's temporary folder: nothing here writes
to /dev. This process's descriptors are reached through a link to /proc/self/fd/N, which
is what /dev/stdout is; before the fix such a link was replaced by a regular file.
"""

from __future__ import annotations

import json
import os
import stat
import threading
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.cli import main
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import (
    check_new_file,
    check_output,
    check_output_dir,
    destination,
    open_output,
    output_file,
    write_output,
)
from tests.trials.test_run_fingerprint_and_outputs import _start, _stub_trials, files  # noqa: F401 (a fixture)


def _fd_link(tmp_path: Path, fd: int, name: str = "stdout") -> Path:
    """A link shaped like /dev/stdout: to this process's descriptor ``fd``."""
    link = tmp_path / name
    link.symlink_to(f"/proc/self/fd/{fd}")
    return link


def _char_device(tmp_path: Path, name: str, minor: int) -> Path:
    """A character device node in tmp_path (1,3 is null, 1,7 is full); skipped where mknod is not allowed."""
    node = tmp_path / name
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, minor))
        with open(node, "wb"):
            pass
    except (PermissionError, OSError) as exc:
        pytest.skip(f"no device nodes here ({exc})")
    return node


class _FifoReader:
    """Reads a FIFO in a thread (its writer's open waits for a reader)."""

    def __init__(self, path: Path) -> None:
        os.mkfifo(path)
        self.path, self.data = path, b""
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        with open(self.path, "rb") as fh:
            self.data = fh.read()

    def result(self) -> bytes:
        self.thread.join(timeout=10)
        assert not self.thread.is_alive()
        return self.data


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_a_link_to_this_process_stdout_like_fd_is_written_not_replaced(tmp_path):
    target = tmp_path / "redirected.txt"
    with open(target, "wb") as fh:
        fh.write(b"before\n")
        fh.flush()
        link = _fd_link(tmp_path, fh.fileno())
        assert destination(link).kind == "fd"
        write_output(link, "after\n")
        fh.flush()
        assert link.is_symlink()  # the link itself is untouched (was: replaced by a file)
    assert target.read_text() == "before\nafter\n"  # appended where the descriptor stood


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_score_json_to_a_stdout_link_keeps_the_link(tmp_path, files, monkeypatch):  # noqa: F811
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    read, write = os.pipe()
    try:
        link = _fd_link(tmp_path, write)
        assert main(["score", str(run_dir), "--json", str(link)]) == 0
        os.close(write)
        write = -1
        with os.fdopen(read, "rb") as fh:
            read = -1
            doc = json.loads(fh.read())
    finally:
        for fd in (read, write):
            if fd >= 0:
                os.close(fd)
    assert doc["seed"] == 0 and link.is_symlink()


def test_json_dash_is_standard_output(tmp_path, files, monkeypatch, capsysbinary):  # noqa: F811
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_start(run_dir, files)) == 0
    capsysbinary.readouterr()
    monkeypatch.chdir(tmp_path)
    assert main(["score", str(run_dir), "--json", "-"]) == 0
    out = capsysbinary.readouterr().out.decode()
    assert '"seed": 0' in out and not (tmp_path / "-").exists()


def test_a_fifo_gets_the_bytes_and_stays_a_fifo(tmp_path, files, monkeypatch):  # noqa: F811
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    fifo = tmp_path / "summary.fifo"
    reader = _FifoReader(fifo)
    assert main([*_start(run_dir, files), "--json", str(fifo)]) == 0
    assert json.loads(reader.result())["seed"] == 0
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_link_to_a_fifo_is_followed_as_a_stream(tmp_path):
    fifo = tmp_path / "pipe"
    reader = _FifoReader(fifo)
    link = tmp_path / "out.json"
    link.symlink_to(fifo)
    write_output(link, "{}\n")
    assert reader.result() == b"{}\n" and link.is_symlink()


def test_a_character_device_is_written_and_stays_a_device(tmp_path, files, monkeypatch):  # noqa: F811
    null = _char_device(tmp_path, "null", 3)
    link = tmp_path / "to_null"
    link.symlink_to(null)
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main([*_start(run_dir, files), "--json", str(link)]) == 0
    assert stat.S_ISCHR(os.lstat(null).st_mode) and link.is_symlink()


def test_a_full_device_is_one_error_line_and_stays_a_device(tmp_path, files, monkeypatch, capsys):  # noqa: F811
    full = _char_device(tmp_path, "full", 7)
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    status = main([*_start(run_dir, files), "--json", str(full)])
    err = capsys.readouterr().err
    assert status != 0 and "Traceback" not in err and "No space left" in err
    assert stat.S_ISCHR(os.lstat(full).st_mode)


def test_streams_need_no_force_and_pass_any_format(tmp_path):
    null = _char_device(tmp_path, "null", 3)
    check_new_file(null, "--out", force=False)  # not replaced, so no --force
    assert check_output(null, "--png", formats=("png",)) == null
    assert check_output("-", "--json") == Path("-")
    regular = tmp_path / "x.csv"
    regular.write_text("a\n")
    with pytest.raises(UsageError, match="exists"):
        check_new_file(regular, "--out", force=False)


def test_output_file_sends_a_temporary_file_to_the_stream(tmp_path):
    fifo = tmp_path / "pipe"
    reader = _FifoReader(fifo)
    with output_file(fifo) as tmp:
        assert tmp.parent != tmp_path
        tmp.write_bytes(b"x" * 3_000_000)  # larger than a pipe's buffer and one chunk
    assert reader.result() == b"x" * 3_000_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]


def test_a_socket_is_refused_naming_the_flag(tmp_path):
    import socket

    path = tmp_path / "sock"
    server = socket.socket(socket.AF_UNIX)
    try:
        server.bind(str(path))
        with pytest.raises(UsageError, match="--json .*a socket"):
            check_output(path, "--json")
    finally:
        server.close()


def test_folder_outputs_refuse_dash_and_streams(tmp_path, files, monkeypatch, capsys):  # noqa: F811
    null = _char_device(tmp_path, "null", 3)
    for bad in ("-", str(null)):
        with pytest.raises(UsageError, match="a folder"):
            check_output_dir(bad, "--out")
    _stub_trials(monkeypatch)
    monkeypatch.chdir(tmp_path)
    argv = _start(tmp_path / "unused", files)
    argv[argv.index("--out") + 1] = "-"
    assert main(argv) == 2
    assert "a folder" in capsys.readouterr().err and not (tmp_path / "-").exists()


def test_recorder_writes_to_a_fifo_and_replaces_a_link_to_a_file(tmp_path):
    from grasp_ctrl.tactile_link.recorder import FrameRecorder

    fifo = tmp_path / "frames"
    reader = _FifoReader(fifo)
    rec = FrameRecorder(fifo)
    rec.close()
    assert reader.result().startswith(b"t_recv,finger,seq")
    victim = tmp_path / "victim.csv"
    victim.write_text("keep\n")
    link = tmp_path / "rec.csv"
    link.symlink_to(victim)
    FrameRecorder(link).close()
    assert victim.read_text() == "keep\n" and not link.is_symlink()


def test_open_output_on_dash_leaves_stdout_open(tmp_path, capfdbinary):
    with open_output("-") as fh:
        fh.write(b"hello\n")
    os.write(1, b"still open\n")
    assert capfdbinary.readouterr().out == b"hello\nstill open\n"


_NAMES = st.sampled_from(["plain", "link_file", "link_missing", "fifo", "link_fifo", "fd_link", "dash"])


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=_NAMES, payload=st.binary(min_size=0, max_size=70_000))
def test_every_kind_of_output_path_gets_the_bytes_and_keeps_its_kind(tmp_path_factory, capfdbinary, kind, payload):
    tmp = tmp_path_factory.mktemp("out")
    victim = tmp / "victim"
    victim.write_bytes(b"victim")
    path, reader, pipe = tmp / "out.bin", None, None
    if kind == "plain":
        path.write_bytes(b"old")
    elif kind == "link_file":
        path.symlink_to(victim)
    elif kind == "link_missing":
        path.symlink_to(tmp / "nowhere")
    elif kind == "fifo":
        reader = _FifoReader(path)
    elif kind == "link_fifo":
        reader = _FifoReader(tmp / "fifo")
        path.symlink_to(tmp / "fifo")
    elif kind == "fd_link":
        pipe = os.pipe()
        path.symlink_to(f"/proc/self/fd/{pipe[1]}")
    else:
        path = Path("-")
    capfdbinary.readouterr()
    if kind == "fd_link":
        chunks: list[bytes] = []

        def _drain() -> None:
            while True:
                chunk = os.read(pipe[0], 65536)
                if not chunk:
                    return
                chunks.append(chunk)

        drain = threading.Thread(target=_drain, daemon=True)
        drain.start()
        write_output(path, payload)
        os.close(pipe[1])
        drain.join(timeout=10)
        os.close(pipe[0])
        assert b"".join(chunks) == payload and path.is_symlink()
    else:
        write_output(path, payload)
    if kind in ("plain", "link_file", "link_missing"):
        assert not path.is_symlink() and path.read_bytes() == payload
    elif reader is not None:
        assert reader.result() == payload and (path.is_symlink() or stat.S_ISFIFO(os.lstat(path).st_mode))
    elif kind == "dash":
        assert capfdbinary.readouterr().out == payload
    assert victim.read_bytes() == b"victim"
    assert not [p for p in tmp.iterdir() if p.name.endswith(".tmp")]
