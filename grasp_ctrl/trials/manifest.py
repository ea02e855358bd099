"""``RUN_DIR/run.json``: everything needed to continue a run exactly.

Written before the first trial. The object profiles are stored in full (not
just their names) so a resumed run uses the thresholds the run started with
even if the object file was tuned in between; the hand file is stored by path
with a hash so a changed file is noticed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.controller.settings import ControllerSettings
from grasp_ctrl.errors import UsageError
from grasp_ctrl.trials.storage import RUN_FILE, write_json

FORMAT = 1


@dataclass
class RunManifest:
    backend: str
    hand: str                       # the hand's name (summary "hand")
    seed: int
    trials: int
    policies: list[str]
    objects: list[ObjectProfile]
    tick_logs: bool = True
    hand_file: str | None = None
    hand_sha256: str | None = None
    object_file: str | None = None
    preset: str | None = None
    settings: ControllerSettings = field(default_factory=ControllerSettings)

    @property
    def object_names(self) -> list[str]:
        return [o.name for o in self.objects]

    @property
    def total(self) -> int:
        return len(self.policies) * len(self.objects) * self.trials

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "backend": self.backend,
            "hand": self.hand,
            "hand_file": self.hand_file,
            "hand_sha256": self.hand_sha256,
            "object_file": self.object_file,
            "preset": self.preset,
            "seed": self.seed,
            "trials": self.trials,
            "policies": list(self.policies),
            "objects": [dataclasses.asdict(o) for o in self.objects],
            "tick_logs": self.tick_logs,
            "settings": dataclasses.asdict(self.settings),
        }

    @classmethod
    def from_json(cls, doc: Any, where: str) -> "RunManifest":
        def bad(what: str) -> UsageError:
            return UsageError(f"{where}: {what}")

        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise bad(f"not a run file of format {FORMAT}")
        try:
            objects = [_profile(o) for o in doc["objects"]]
            settings = _settings(doc.get("settings") or {})
            m = cls(
                backend=str(doc["backend"]), hand=str(doc["hand"]), seed=int(doc["seed"]),
                trials=int(doc["trials"]), policies=[str(p) for p in doc["policies"]], objects=objects,
                tick_logs=bool(doc.get("tick_logs", True)), hand_file=doc.get("hand_file"),
                hand_sha256=doc.get("hand_sha256"), object_file=doc.get("object_file"),
                preset=doc.get("preset"), settings=settings,
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise bad(f"unreadable run parameters ({exc.__class__.__name__}: {exc})") from None
        if m.trials < 1 or not m.policies or not m.objects:
            raise bad("needs at least one trial, policy and object")
        return m

    def same_plan(self, other: "RunManifest") -> bool:
        """Would both produce the same trials? (paths and presets may differ)"""
        a, b = self.to_json(), other.to_json()
        keys = ("backend", "hand", "seed", "trials", "policies", "objects", "tick_logs", "settings")
        return all(a[k] == b[k] for k in keys)


def _profile(d: dict[str, Any]) -> ObjectProfile:
    d = dict(d)
    d["size_m"] = tuple(d["size_m"])
    return ObjectProfile(**d)


def _settings(d: dict[str, Any]) -> ControllerSettings:
    known = {f.name for f in dataclasses.fields(ControllerSettings)}
    return ControllerSettings(**{k: v for k, v in d.items() if k in known})


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def manifest_path(run_dir: Path) -> Path:
    return run_dir / RUN_FILE


def write_manifest(run_dir: Path, m: RunManifest) -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    write_json(manifest_path(run_dir), m.to_json())


def read_manifest(run_dir: Path) -> RunManifest | None:
    """The run's parameters, or None when the directory has no run file."""
    path = manifest_path(run_dir)
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UsageError(f"{path}: unreadable run file ({exc.__class__.__name__})") from None
    return RunManifest.from_json(doc, str(path))
