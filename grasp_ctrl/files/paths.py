"""Where the shipped hand configs and policies live (the repository's top level).

The package is installed in editable mode (README), so these are the checkout's
``hand_configs/`` and ``policies/``; ``GRASP_CTRL_HAND_CONFIGS`` and
``GRASP_CTRL_POLICIES`` override them.
"""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]


def hand_configs_dir() -> Path:
    return Path(os.environ.get("GRASP_CTRL_HAND_CONFIGS", REPO_ROOT / "hand_configs"))


def policies_dir() -> Path:
    return Path(os.environ.get("GRASP_CTRL_POLICIES", REPO_ROOT / "policies"))


def default_hand_file() -> Path:
    return hand_configs_dir() / "leap_hand.toml"


def default_objects_file() -> Path:
    return hand_configs_dir() / "objects.toml"
