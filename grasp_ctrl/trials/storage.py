"""Where a run's files live and how they are written (atomically, fsynced).

    RUN_DIR/run.json                              the run's parameters (resume reads them)
    RUN_DIR/summary.json                          the run summary (DESIGN.md 5.2)
    RUN_DIR/trials/POLICY/OBJECT/trial_NNN.json   one record per finished trial
    RUN_DIR/trials/POLICY/OBJECT/trial_NNN_ticks.parquet   per-tick log (ticklog.py)
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

RUN_FILE = "run.json"
SUMMARY_FILE = "summary.json"
TRIALS_DIR = "trials"


def safe_name(name: str) -> str:
    """A policy spec such as ``oracle:scale=2`` or a path, as one directory name."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def trial_dir(run_dir: Path, policy: str, obj: str) -> Path:
    return run_dir / TRIALS_DIR / safe_name(policy) / obj


def record_path(run_dir: Path, policy: str, obj: str, trial: int) -> Path:
    return trial_dir(run_dir, policy, obj) / f"trial_{trial:03d}.json"


def ticks_path(run_dir: Path, policy: str, obj: str, trial: int) -> Path:
    return trial_dir(run_dir, policy, obj) / f"trial_{trial:03d}_ticks.parquet"


def write_json(path: Path, doc: Any) -> None:
    """Write atomically and fsync (file and directory): a crash loses at most the trial in progress."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    with tmp.open("w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=2)
        fh.write("\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def _fsync_dir(path: Path) -> None:
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
