"""What ``tune`` checks before Optuna is imported: the extra is there, the storage URL is usable."""

from __future__ import annotations

import contextlib
from pathlib import Path

from grasp_ctrl.errors import UsageError

DEFAULT_BUDGET = 20  # settings in a study with a continuous range, unless --budget says otherwise


def require_optuna() -> None:
    try:
        import optuna  # noqa: F401
    except ImportError:
        raise UsageError("tune needs Optuna: pip install -e '.[tune]'") from None


def check_storage(url: str) -> None:
    """``sqlite:///FILE`` (the folder must exist; an existing FILE empty or an Optuna storage) or
    another database URL Optuna takes."""
    if "://" not in url:
        raise UsageError(f"--storage {url}: a database URL, e.g. sqlite:///study.db")
    if url.startswith("sqlite:///"):
        name = url[len("sqlite:///") :]
        path = Path(name)
        if not name.strip() or "\x00" in name:
            raise UsageError(f"--storage {url}: no file named")
        if not path.parent.is_dir():
            raise UsageError(f"--storage {url}: folder {path.parent} does not exist")
        if path.exists() and not path.is_file():
            raise UsageError(f"--storage {url}: {path} is not a file")
        if path.is_file():
            check_sqlite_tables(url, path)


# Every Optuna storage has these; Optuna adds its other tables to any database it opens.
OPTUNA_MARKS = frozenset({"studies", "trials", "version_info"})


def check_sqlite_tables(url: str, path: Path) -> None:
    """An existing SQLite file is used only if it is empty or already an Optuna storage: Optuna
    would otherwise add its tables to another program's database without a word."""
    import sqlite3

    try:  # read-only: the check itself writes nothing
        with contextlib.closing(sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)) as db:
            tables = sorted(row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'"))
    except sqlite3.OperationalError:  # locked or unreadable: Optuna says why when it opens it
        return
    except sqlite3.DatabaseError:
        raise UsageError(f"--storage {url}: {path} is not a SQLite database") from None
    if tables and not OPTUNA_MARKS <= set(tables):
        other = next((t for t in tables if t not in OPTUNA_MARKS), tables[0])
        raise UsageError(
            f"--storage {url}: {path} is another program's database (table {other!r}), not an Optuna "
            "study's; name a new file"
        )
