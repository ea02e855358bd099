"""What ``tune`` checks before Optuna is imported: the extra is there, the storage URL is usable."""

from __future__ import annotations

from pathlib import Path

from grasp_ctrl.errors import UsageError

DEFAULT_BUDGET = 20  # settings in a study with a continuous range, unless --budget says otherwise


def require_optuna() -> None:
    try:
        import optuna  # noqa: F401
    except ImportError:
        raise UsageError("tune needs Optuna: pip install -e '.[tune]'") from None


def check_storage(url: str) -> None:
    """``sqlite:///FILE`` (the folder must exist) or another database URL Optuna takes."""
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
