"""Writing only where asked: outputs, a run's managed files and edits in place.

An output path a user names is one of (:func:`destination`):

- ``-``: standard output;
- a stream: a character device (``/dev/null``, a terminal), a FIFO, or a link to one of
  them, and this process's own descriptors (``/dev/stdout``, ``/dev/stderr``,
  ``/dev/fd/N``, ``/proc/self/fd/N``, whatever they point at). A stream is opened and
  written, never replaced, created or truncated;
- a file: a regular file, a path that does not exist yet, or a symlink that is not one of
  the above (the link is replaced by the new file; its target is never written);
- anything else (a block device, a socket, a directory) is refused on one line.

- :func:`check_output` refuses an output path (``--json``, ``--png``, ``--out``) that
  is one of a run's managed files (``run.json``, ``summary.json``, ``run.lock``, a
  trial record or tick log), a directory, or (with ``formats``) has an extension
  the writer does not know; it says so on one line naming the flag.
- :func:`write_output` / :func:`output_file` write a file under a temporary name
  beside it and rename it into place (a stream gets the bytes instead).
- :func:`save_figure` saves a matplotlib figure that way, its format checked.
- :func:`replace_in_place` edits an existing file: a symlink is resolved to its
  target (the target changes, the link stays), and the new file keeps the old
  one's mode and owner.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import sys
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, Literal, overload

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.storage import fsync_dir, temp_path

RUN_FILE = "run.json"  # = trials.storage.RUN_FILE (no import: storage is heavier and imports us)
MANAGED_TOP = ("run.json", "summary.json", "run.lock")
MANAGED_TRIAL = re.compile(r"^(trial_\d{3,}\.json|trial_\d{3,}_ticks\.(parquet|csv))$")
IMAGE_FORMATS = ("png", "pdf", "svg", "svgz", "jpg", "jpeg", "eps", "ps", "tif", "tiff", "webp", "pgf", "raw", "rgba")
STDOUT = "-"
# /proc/PID/fd/N and /proc/PID/task/TID/fd/N, as /proc/self, /proc/thread-self and /dev/fd resolve
_PROC_FD = re.compile(r"^/proc/(\d+)(?:/task/\d+)?/fd/(\d+)$")
_MAX_LINKS = 40  # as the kernel's own limit on a chain of symlinks


@dataclass(frozen=True)
class Destination:
    """Where an output goes: ``kind`` is ``file`` (replaced by a new file), ``stream`` (a
    character device or FIFO, opened and written), ``fd`` (this process's descriptor ``fd``)
    or ``stdout`` (``-``)."""

    path: Path
    kind: Literal["file", "stream", "fd", "stdout"]
    fd: int = -1

    @property
    def is_stream(self) -> bool:
        return self.kind != "file"


def _own_descriptor(text: str) -> int | None:
    """The descriptor of this process that ``text`` names through a chain of links
    (``/dev/stdout`` -> ``/proc/self/fd/1``), else None. Read link by link: the last
    link of /proc/self/fd/N names a pipe or socket, or the file stdout was redirected to,
    which must not be replaced."""
    current = os.path.abspath(text)
    for _ in range(_MAX_LINKS):
        current = os.path.join(os.path.realpath(os.path.dirname(current)), os.path.basename(current))
        match = _PROC_FD.match(current)
        if match and int(match.group(1)) == os.getpid():
            return int(match.group(2))
        if not os.path.islink(current):
            return None
        try:
            target = os.readlink(current)
        except OSError:
            return None
        current = os.path.normpath(os.path.join(os.path.dirname(current), target))
    return None


def _kind_name(mode: int) -> str:
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISDIR(mode):
        return "a directory"
    return "not a regular file"


def destination(path: str | Path, flag: str = "output") -> Destination:
    """What writing ``path`` means (see the module's doc); a block device or a socket (or a
    link to one) is a UsageError naming ``flag``."""
    text = str(path)
    if text == STDOUT:
        return Destination(Path(STDOUT), "stdout")
    p = Path(text)
    fd = _own_descriptor(text)
    if fd is not None:
        try:
            os.fstat(fd)
        except OSError:
            raise UsageError(f"{flag} {p}: descriptor {fd} is not open in this process") from None
        return Destination(p, "fd", fd)
    try:
        mode = os.stat(p).st_mode  # through links: what a link points at decides
    except OSError:
        return Destination(p, "file")  # new, or a dangling link (replaced, never followed)
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return Destination(p, "stream")
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode) or p.is_symlink():
        return Destination(p, "file")  # a folder is the callers' to refuse; a link is replaced
    raise UsageError(f"{flag} {p}: {_kind_name(mode)}; give a file, a character device, a FIFO or {STDOUT}")


def _flush_printed() -> None:
    """What this process printed comes before bytes written to its own descriptors."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()


def _open_device(dest: Destination, flag: str) -> int:
    """A ``stream`` destination opened for writing, without creating or truncating anything (a
    FIFO waits here for its reader), and checked to be what :func:`destination` saw."""
    fd = os.open(dest.path, os.O_WRONLY | os.O_NOCTTY)
    mode = os.fstat(fd).st_mode
    if not (stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)):
        os.close(fd)
        raise UsageError(f"{flag} {dest.path}: changed while being opened; nothing written")
    return fd


def _write_stream(dest: Destination, chunks: Iterable[bytes], flag: str = "output") -> None:
    """The bytes written to a stream destination: opened without creating or truncating
    anything, checked to be what :func:`destination` saw, written whole."""
    if dest.kind == "stdout":
        sys.stdout.flush()
        out = getattr(sys.stdout, "buffer", None)
        for chunk in chunks:
            if out is not None:
                out.write(chunk)
            else:  # a text-only stdout (some embedders)
                sys.stdout.write(chunk.decode("utf-8", errors="replace"))
        (out or sys.stdout).flush()
        return
    if dest.kind == "fd":
        _flush_printed()
        fd, close = dest.fd, False
    else:
        fd, close = _open_device(dest, flag), True
    try:
        for chunk in chunks:
            view = memoryview(chunk)
            while view:
                view = view[os.write(fd, view) :]
    finally:
        if close:
            os.close(fd)


def open_output(path: str | Path, flag: str = "output") -> BinaryIO:
    """A binary file object for an output written as it goes (a recording): a stream is
    opened as such (standard output and this process's descriptors through a duplicate, so
    closing it leaves them open); a file is created or truncated, a symlink there replaced
    by a new file, never followed."""
    dest = destination(path, flag)
    if dest.kind == "stdout" or dest.kind == "fd":
        _flush_printed()
        fd = os.dup(1 if dest.kind == "stdout" else dest.fd)
    elif dest.kind == "stream":
        fd = _open_device(dest, flag)
    else:
        if dest.path.is_symlink():  # a new file replaces the link; its target is never written
            dest.path.unlink()
        fd = os.open(dest.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0), 0o666)
    return os.fdopen(fd, "wb")


def write_stream(path: str | Path, data: str | bytes, flag: str = "output") -> Destination:
    """``data`` written to ``path`` when it is a stream (see :func:`destination`); returns the destination
    (a ``file`` destination is left to the caller)."""
    dest = destination(path, flag)
    if dest.is_stream:
        _write_stream(dest, [data.encode("utf-8") if isinstance(data, str) else data], flag)
    return dest


def _destinations(path: Path) -> list[Path]:
    """What writing ``path`` would replace: the name in its real folder, and where a symlink there points."""
    parent = Path(os.path.realpath(path.parent if str(path.parent) else "."))
    out = [parent / path.name]
    if path.is_symlink():
        out.append(Path(os.path.realpath(path)))
    return out


def managed_by_run(path: Path, run_dirs: Iterable[Path] = ()) -> Path | None:
    """The run directory whose managed file ``path`` is (or would replace), else None."""
    known = [Path(os.path.realpath(d)) for d in run_dirs]
    for dest in _destinations(path):
        for folder in dest.parents:
            if folder in known or (folder / RUN_FILE).is_file():
                rel = dest.relative_to(folder).parts
                if (len(rel) == 1 and rel[0] in MANAGED_TOP) or (
                    len(rel) == 4 and rel[0] == "trials" and MANAGED_TRIAL.match(rel[-1])
                ):
                    return folder
    return None


@overload
def check_output(
    path: str | Path, flag: str, *, run_dirs: Iterable[Path] = (), formats: Iterable[str] | None = None
) -> Path: ...


@overload
def check_output(
    path: str | Path | None, flag: str, *, run_dirs: Iterable[Path] = (), formats: Iterable[str] | None = None
) -> Path | None: ...


def check_output(
    path: str | Path | None, flag: str, *, run_dirs: Iterable[Path] = (), formats: Iterable[str] | None = None
) -> Path | None:
    """``path`` checked as an output of ``flag`` (see the module's doc); None passes through."""
    if path is None:
        return None
    text = str(path)
    if not text.strip():
        raise UsageError(f"{flag}: an empty path")
    p = Path(text)
    if destination(p, flag).is_stream:
        return p  # written as a stream: no file is replaced, any format goes to it
    run = managed_by_run(p, run_dirs)
    if run is not None:
        raise UsageError(f"{flag} {p}: a file that the run in {run} manages; choose another path")
    if p.is_dir() and not p.is_symlink():
        raise UsageError(f"{flag} {p}: is a directory; give a file name")
    if formats is not None:
        allowed = sorted(set(formats))
        ext = p.suffix.lower().lstrip(".")
        if ext not in allowed:
            raise UsageError(
                f"{flag} {p}: an extension of {', '.join('.' + f for f in allowed)} (got {p.suffix or 'none'})"
            )
    return p


def check_new_file(path: Path, flag: str, force: bool) -> None:
    """An output file that an existing one may be replaced by only with ``--force``, in a folder
    that exists; ``flag``: the option named in errors. A stream (``-``, a device, a FIFO) is
    never replaced, so it needs no ``--force``."""
    if destination(path, flag).is_stream:
        return
    if path.exists() and not force:
        raise UsageError(f"{flag}: {path} exists (use --force to overwrite)")
    if not path.parent.is_dir():
        raise UsageError(f"{flag}: {path.parent}: no such folder")


def same_file(a: Path, b: Path) -> bool:
    """Whether writing ``a`` would replace the file ``b`` names: the same path once links and
    ``..`` are resolved, or the same file by another name (a hard link)."""
    if Path(os.path.realpath(a)) == Path(os.path.realpath(b)):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # either does not exist (yet): not the same file
        return False


def temp_beside(path: Path, keep_suffix: bool = False) -> Path:
    """``storage.temp_path`` (``.NAME.PID.RANDOM.tmp``), with ``path``'s own suffix appended when
    ``keep_suffix`` (a writer such as matplotlib reads the format from the name)."""
    tmp = temp_path(path)
    return tmp.with_name(tmp.name + path.suffix) if keep_suffix else tmp


@contextlib.contextmanager
def output_file(path: str | Path, keep_suffix: bool = True) -> Iterator[Path]:
    """``with output_file(p) as tmp: write tmp``: ``tmp`` is renamed onto ``p`` on success
    (replacing a symlink there, never following it) and removed on error. When ``p`` is a
    stream (``-``, a device, a FIFO, ``/dev/stdout``), ``tmp`` lies in a private temporary
    folder and its bytes are written to the stream instead."""
    dest = destination(path)
    if dest.is_stream:
        with tempfile.TemporaryDirectory(prefix="grasp_ctrl-out-") as folder:
            name = "output" + (Path(str(path)).suffix if keep_suffix and dest.kind != "stdout" else "")
            tmp = Path(folder) / name
            yield tmp
            if not tmp.is_file():
                raise OSError(f"{path}: nothing was written")
            with open(tmp, "rb") as fh:
                _write_stream(dest, iter(lambda: fh.read(1 << 20), b""))
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_beside(path, keep_suffix)
    try:
        yield tmp
        if not tmp.is_file():
            raise OSError(f"{path}: nothing was written")
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        _keep_mode_and_owner(path, tmp)
        os.replace(tmp, path)
        fsync_dir(path.parent)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def _keep_mode_and_owner(old: Path, new: Path) -> None:
    """A regular file being replaced passes its mode (and, where allowed, owner) to the new one."""
    try:
        st = os.lstat(old)
    except OSError:
        return
    if stat.S_ISREG(st.st_mode):
        os.chmod(new, stat.S_IMODE(st.st_mode))
        with contextlib.suppress(OSError):
            os.chown(new, st.st_uid, st.st_gid)


def write_output(path: str | Path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` as a new file, or to the stream ``path`` names (see
    :func:`destination`)."""
    if write_stream(path, data).is_stream:
        return Path(path)
    with output_file(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o666)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
    return Path(path)


def image_formats(fig: Any = None) -> tuple[str, ...]:
    """The extensions matplotlib can save (its canvas's list when a figure is given)."""
    if fig is not None:
        with contextlib.suppress(Exception):
            return tuple(fig.canvas.get_supported_filetypes())
    return IMAGE_FORMATS


def save_figure(fig: Any, path: str | Path, flag: str = "--out", **kwargs: Any) -> Path:
    """``fig.savefig`` to ``path`` through a temporary file, in the format its extension names."""
    p = Path(path)
    fmt = p.suffix.lower().lstrip(".")
    allowed = image_formats(fig)
    if destination(p, flag).is_stream and fmt not in allowed:
        fmt = "png"  # a stream's name says nothing of the format
    if fmt not in allowed:
        raise UsageError(
            f"{flag} {p}: an extension of {', '.join('.' + f for f in sorted(allowed))} (got {p.suffix or 'none'})"
        )
    with output_file(p) as tmp:
        fig.savefig(tmp, format=fmt, **kwargs)
    return p


def replace_in_place(path: str | Path, data: str | bytes) -> Path:
    """Replace the content of the existing file ``path`` (an edit such as ``tune --write``).

    A symlink is followed to its target, which is the file that changes (the link stays a
    link). The new content is written beside the target, given the target's mode and owner
    (when this process may not set the owner, the target is rewritten in place instead, which
    keeps both), fsynced and renamed over it. Returns the file that was written."""
    target = Path(os.path.realpath(path))
    try:
        st = os.stat(target)
    except FileNotFoundError:
        raise UsageError(f"{path}: no such file to edit") from None
    if not stat.S_ISREG(st.st_mode):
        raise UsageError(f"{path}: not a regular file; nothing written")
    raw = data.encode("utf-8") if isinstance(data, str) else data
    tmp = temp_beside(target)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, stat.S_IMODE(st.st_mode))
        now = os.stat(tmp)
        if (now.st_uid, now.st_gid) != (st.st_uid, st.st_gid):
            try:
                os.chown(tmp, st.st_uid, st.st_gid)
            except PermissionError:
                tmp.unlink()
                with open(target, "r+b") as fh:  # keeps owner and mode; not atomic
                    fh.truncate(0)
                    fh.write(raw)
                    fh.flush()
                    os.fsync(fh.fileno())
                return target
        os.replace(tmp, target)
        fsync_dir(target.parent)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return target


def check_output_dir(path: str | Path, flag: str) -> Path:
    """A folder that a command writes several files into: ``-`` and streams (a device, a FIFO)
    hold one file only, so they are refused naming ``flag``."""
    text = str(path)
    if not text.strip():
        raise UsageError(f"{flag}: an empty path")
    if text == STDOUT or destination(text, flag).is_stream:
        raise UsageError(f"{flag} {text}: a folder for several files; {STDOUT} and streams take a single file")
    return Path(text)


def check_run_tree(run_dir: Path, flag: str) -> None:
    """A run directory whose files would land elsewhere is refused: ``--out`` naming a symlink,
    or a symlinked folder inside its ``trials`` tree (records would be written through it)."""
    check_output_dir(run_dir, flag)
    run_dir = Path(run_dir)
    if flag == "--out" and run_dir.is_symlink():
        raise UsageError(f"--out {run_dir}: a symlink; give the directory itself")
    trials = run_dir / "trials"
    for folder in (trials, *sorted(trials.glob("*")), *sorted(trials.glob("*/*"))):
        if folder.is_symlink():
            raise UsageError(f"{flag} {run_dir}: {folder} is a symlink; a run's files stay inside its directory")
