"""Where a run's files live and how they are written (atomically, fsynced).

    RUN_DIR/run.json                              the run's parameters (resume reads them)
    RUN_DIR/run.lock                              held while a process writes the run
    RUN_DIR/summary.json                          the run summary (docs/design.md 5.2)
    RUN_DIR/trials/POLICY/OBJECT/trial_NNN.json   one record per finished trial
    RUN_DIR/trials/POLICY/OBJECT/trial_NNN_ticks.parquet   per-tick log (ticklog.py)

Every file is written to a temporary name unique to the writer
(``.NAME.PID.RANDOM.tmp`` in the same directory), fsynced, renamed over the
final name and the directory fsynced: a reader sees the old file or the whole
new one, never a part, and two writers never share a temporary file.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import secrets
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from grasp_ctrl.config.identifiers import check_identifier_arg
from grasp_ctrl.files.names import path_component

RUN_FILE = "run.json"
LOCK_FILE = "run.lock"
SUMMARY_FILE = "summary.json"
TRIALS_DIR = "trials"
TMP_SUFFIX = ".tmp"


def safe_name(name: str) -> str:
    """A policy spec such as ``oracle:scale=2`` or a path, as one directory name."""
    return path_component(name)


def check_object_name(name: str) -> str:
    """``name`` if it is an identifier (config/identifiers.py), else a one-line UsageError."""
    return check_identifier_arg(name, "object name")


def trial_dir(run_dir: Path, policy: str, obj: str) -> Path:
    return run_dir / TRIALS_DIR / safe_name(policy) / check_object_name(obj)


def record_path(run_dir: Path, policy: str, obj: str, trial: int) -> Path:
    return trial_dir(run_dir, policy, obj) / f"trial_{trial:03d}.json"


def interrupted_path(run_dir: Path, policy: str, obj: str, trial: int) -> Path:
    """The record of a trial that Ctrl-C or SIGTERM ended (not a finished trial: resume runs it again)."""
    return trial_dir(run_dir, policy, obj) / f"trial_{trial:03d}.interrupted.json"


def ticks_path(run_dir: Path, policy: str, obj: str, trial: int) -> Path:
    return trial_dir(run_dir, policy, obj) / f"trial_{trial:03d}_ticks.parquet"


def temp_path(path: Path) -> Path:
    """A temporary name beside ``path`` that no other writer (process or call) uses."""
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}{TMP_SUFFIX}")


def is_temp_file(path: Path) -> bool:
    return path.name.startswith(".") and path.name.endswith(TMP_SUFFIX)


def commit_temp(tmp: Path, path: Path, sync_dir: bool = True) -> None:
    """Move a finished (closed and fsynced) temporary file onto its final name (and, with
    ``sync_dir``, fsync the folder so that the new name survives a crash)."""
    os.replace(tmp, path)
    if sync_dir:
        fsync_dir(path.parent)


@contextlib.contextmanager
def atomic_writer(path: str | Path, mode: str = "w", sync_dir: bool = True, **open_kwargs: Any) -> Iterator[IO[Any]]:
    """``with atomic_writer(p) as fh: ...``: ``p`` appears complete on success, untouched on
    error; its content is fsynced, and with ``sync_dir`` also its name (``commit_temp``)."""
    path = Path(path)
    tmp = temp_path(path)
    if "b" not in mode:
        open_kwargs.setdefault("encoding", "utf-8")
    try:
        with open(tmp, mode, **open_kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        commit_temp(tmp, path, sync_dir)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_text_atomic(path: str | Path, text: str) -> None:
    with atomic_writer(path) as fh:
        fh.write(text)


NON_FINITE_KEY = "non_finite"


def finite_json(doc: Any) -> tuple[Any, dict[str, str]]:
    """``doc`` with every NaN and infinity replaced by None (JSON's null), and what each was by
    its path (``peak_forces.index.force_est_n``, ``transitions[3][0]``): Python writes them as
    ``NaN`` and ``Infinity``, which no strict JSON reader loads. ``doc`` itself is not changed."""
    found: dict[str, str] = {}

    def clean(value: Any, where: str) -> Any:
        if isinstance(value, float) and not math.isfinite(value):
            found[where or "$"] = repr(float(value))  # 'inf', '-inf', 'nan'
            return None
        if isinstance(value, dict):
            return {k: clean(v, f"{where}.{k}" if where else str(k)) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [clean(v, f"{where}[{i}]") for i, v in enumerate(value)]
        return value

    return clean(doc, ""), found


def strict_json_text(doc: Any) -> str:
    """``doc`` as strict JSON text (indented, newline-terminated): non-finite numbers are null and,
    in an object, listed under ``non_finite`` (path -> what it was) so readers know why."""
    clean, found = finite_json(doc)
    if found and isinstance(clean, dict):
        before = clean.get(NON_FINITE_KEY)  # a record written again keeps what it said
        clean[NON_FINITE_KEY] = {**(before if isinstance(before, dict) else {}), **found}
    return json.dumps(clean, indent=2, allow_nan=False) + "\n"


def write_json(path: Path, doc: Any) -> None:
    """Write atomically and fsync (file and directory): a crash loses at most the trial in progress.
    Strict JSON (run.json, summary.json, trial records): see :func:`strict_json_text`."""
    write_text_atomic(path, strict_json_text(doc))


def fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # not possible on every platform (Windows)
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes (hex), read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
