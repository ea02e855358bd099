"""Shared fixtures: the shipped hand and object files, and the real-data folder."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from grasp_ctrl.config import load_hand, load_objects
from grasp_ctrl.files.paths import REPO_ROOT

SHARED_DATA = REPO_ROOT.parent / "shared" / "data"

# The pre-trial solves' results are kept in a folder of this session (the commands the tests
# start inherit it), not in the user's cache (numeric/solve_cache.py).
if "GRASP_CTRL_SOLVE_CACHE" not in os.environ:
    os.environ["GRASP_CTRL_SOLVE_CACHE"] = _SOLVES = tempfile.mkdtemp(prefix="grasp_ctrl-solves-")
    atexit.register(shutil.rmtree, _SOLVES, ignore_errors=True)


@pytest.fixture(scope="session")
def hand():
    return load_hand(REPO_ROOT / "hand_configs" / "leap_hand.toml")


@pytest.fixture(scope="session")
def objects(hand):
    """The shipped objects as the shipped hand runs them (its [objects.NAME.hands.HAND] values)."""
    return load_objects(REPO_ROOT / "hand_configs" / "objects.toml", hand.name)


@pytest.fixture
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present beside the checkout")
    return SHARED_DATA


def sigint_as_at_a_terminal() -> None:
    """``preexec_fn`` for children that a test interrupts with SIGINT: a shell that starts a
    job in the background without job control (as CI runners may) hands its children SIGINT
    ignored, and Python then never raises KeyboardInterrupt. A terminal's Ctrl-C is what the
    tests mean, so restore the default disposition."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.fixture
def sigint_raises():
    """Ctrl-C raises KeyboardInterrupt in this test (a shell without job control may start the
    tests with SIGINT ignored)."""
    import signal

    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def copy_policy(tmp_path: Path, edit, name: str = "icra19_official") -> Path:
    """A copy of the shipped policy ``name`` in ``tmp_path`` (model and metadata), its
    metadata changed by ``edit(meta)``; returns the copy's JSON path."""
    import json
    import shutil

    from grasp_ctrl.files.paths import policies_dir

    shutil.copy(policies_dir() / f"{name}.onnx", tmp_path / f"{name}.onnx")
    meta = json.loads((policies_dir() / f"{name}.json").read_text())
    edit(meta)
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(meta))
    return path


def modules_after(code: str, modules: set[str]) -> set[str]:
    """Which of ``modules`` a fresh interpreter has imported after running ``code`` from the
    repository root: import-cost checks need a process that no other test has loaded modules into."""
    import json
    import subprocess
    import sys

    probe = f"{code}\nimport json, sys; print(json.dumps(sorted(set({sorted(modules)!r}) & set(sys.modules))))"
    out = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        check=True,
        cwd=Path(__file__).resolve().parents[1],
    )
    return set(json.loads(out.stdout))
