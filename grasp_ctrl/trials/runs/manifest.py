"""``RUN_DIR/run.json``: everything needed to continue a run exactly.

Written before the first trial. The object profiles are stored in full (not
just their names) so a resumed run uses the thresholds the run started with
even if the object file was tuned in between; the hand file is stored by path
with a hash so a changed file is noticed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grasp_ctrl.config.objects import ObjectProfile, profile_from_json, profile_json
from grasp_ctrl.controller.paper_settings import PaperSettings
from grasp_ctrl.controller.registry import default_settings, flat_settings, settings_from_flat
from grasp_ctrl.errors import ConfigError, UsageError
from grasp_ctrl.files.json_limits import JsonFileError, read_json
from grasp_ctrl.files.storage import (
    RUN_FILE,
    file_sha256,  # noqa: F401  (run's plan hashes its files with it)
    write_json,
)
from grasp_ctrl.rigs.registry import BACKEND_NAMES
from grasp_ctrl.rigs.registry import backend as backend_entry
from grasp_ctrl.sim.variation import NOMINAL, Variation, variation_from_json

FORMAT = 1
MAX_TRIALS = 100_000


@dataclass
class RunManifest:
    backend: str
    hand: str  # the hand's name (summary "hand")
    seed: int
    trials: int
    policies: list[str]
    objects: list[ObjectProfile]
    tick_logs: bool = True
    # The tick logs keep every raw tactile frame whole (run --raw-frames, --mcap). Not part of
    # the plan or the fingerprint: it changes what is logged, never a trial.
    raw_frames: bool = False
    hand_file: str | None = None
    hand_sha256: str | None = None
    object_file: str | None = None
    preset: str | None = None
    settings: PaperSettings = field(default_factory=default_settings)
    fingerprint: dict[str, Any] | None = None  # trials/runs/fingerprint.py
    forced: list[dict[str, Any]] = field(default_factory=list)  # resumes with --force despite changes
    # The simulated world's per-trial draws (sim/variation.py); None on the real hand.
    variation: Variation | None = NOMINAL
    # The emulated hand on the wall clock (run --emulate --realtime): a resume keeps it.
    realtime: bool = False

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
            "objects": [profile_json(o) for o in self.objects],
            "tick_logs": self.tick_logs,
            "raw_frames": self.raw_frames,
            "controller": self.settings.controller,
            "settings": flat_settings(self.settings),
            "fingerprint": self.fingerprint,
            "forced": list(self.forced),
            "variation": self.variation.to_json() if self.variation is not None else None,
            "realtime": self.realtime,
        }

    @classmethod
    def from_json(cls, doc: Any, where: str) -> RunManifest:
        """Every field checked as on a new run: a hand-edited or corrupt run.json
        gives one line naming the file and the field, never a bad trial."""

        def bad(key: str, what: str) -> UsageError:
            return UsageError(f"{where}: {key}: {what}")

        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise UsageError(f"{where}: not a run file of format {FORMAT}")
        for key in ("backend", "hand", "seed", "trials", "policies", "objects"):
            if key not in doc:
                raise bad(key, "required key is missing")
        backend, hand = doc["backend"], doc["hand"]
        if backend not in BACKEND_NAMES:
            raise bad("backend", f"one of {', '.join(BACKEND_NAMES)} (got {backend!r})")
        if not isinstance(hand, str) or not hand:
            raise bad("hand", "a non-empty string")
        seed, trials = doc["seed"], doc["trials"]
        if not _is_int(seed) or not 0 <= seed < 2**63:
            raise bad("seed", f"an integer from 0 to 2**63-1 (got {seed!r})")
        if not _is_int(trials) or not 1 <= trials <= MAX_TRIALS:
            raise bad("trials", f"an integer from 1 to {MAX_TRIALS} (got {trials!r})")
        policies = doc["policies"]
        if not isinstance(policies, list) or not policies or not all(isinstance(p, str) and p for p in policies):
            raise bad("policies", "a non-empty list of policy names")
        if len(set(policies)) != len(policies):
            raise bad("policies", "each policy once")
        raw_objects = doc["objects"]
        if not isinstance(raw_objects, list) or not raw_objects:
            raise bad("objects", "a non-empty list of object profiles")
        objects = []
        for o in raw_objects:
            name = o.get("name") if isinstance(o, dict) else None
            try:
                objects.append(profile_from_json(name, o, where, "objects."))
            except ConfigError as exc:
                raise UsageError(str(exc)) from None
        names = [o.name for o in objects]
        if len(set(names)) != len(names):
            raise bad("objects", "each object once")
        tick_logs = doc.get("tick_logs", True)
        if not isinstance(tick_logs, bool):
            raise bad("tick_logs", "true or false")
        raw_frames = doc.get("raw_frames", False)  # a run from before the option kept summaries only
        if not isinstance(raw_frames, bool):
            raise bad("raw_frames", "true or false")
        for key in ("hand_file", "hand_sha256", "object_file", "preset"):
            if doc.get(key) is not None and not isinstance(doc[key], str):
                raise bad(key, "a string or null")
        settings = settings_from_json(doc.get("settings") or {}, where)
        fingerprint = check_fingerprint_shape(doc.get("fingerprint"), where)
        forced = doc.get("forced") or []
        if not isinstance(forced, list) or not all(isinstance(f, dict) for f in forced):
            raise bad("forced", "a list of tables (resumes with --force)")
        # A run from before the variation profiles drew the nominal ones; null: the real hand.
        raw_variation = doc.get("variation", NOMINAL.to_json())
        variation = None if raw_variation is None else variation_from_json(raw_variation, where)
        realtime = doc.get("realtime", False)  # a run from before the realtime dry run ran in lockstep
        if not isinstance(realtime, bool):
            raise bad("realtime", "true or false")
        if realtime and backend_entry(backend).kind != "emulated":
            emulated = ", ".join(n for n in BACKEND_NAMES if backend_entry(n).kind == "emulated")
            raise bad("realtime", f"true only with backend {emulated} (got backend {backend!r})")
        return cls(
            backend=backend,
            hand=hand,
            seed=seed,
            trials=trials,
            policies=list(policies),
            objects=objects,
            tick_logs=tick_logs,
            raw_frames=raw_frames,
            hand_file=doc.get("hand_file"),
            hand_sha256=doc.get("hand_sha256"),
            object_file=doc.get("object_file"),
            preset=doc.get("preset"),
            settings=settings,
            fingerprint=fingerprint,
            forced=forced,
            variation=variation,
            realtime=realtime,
        )

    def same_plan(self, other: RunManifest) -> bool:
        """Would both produce the same trials? (paths and presets may differ)"""
        a, b = self.to_json(), other.to_json()
        keys = (
            "backend",
            "hand",
            "seed",
            "trials",
            "policies",
            "objects",
            "tick_logs",
            "settings",
            "variation",
            "realtime",
        )
        return all(a[k] == b[k] for k in keys)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def settings_from_json(d: Any, where: str) -> PaperSettings:
    """Controller settings from run.json's flat table (controller/registry.py, ``settings_from_flat``)."""
    return settings_from_flat(d, where)


def check_fingerprint_shape(doc: Any, where: str) -> dict[str, Any] | None:
    """run.json's ``fingerprint`` checked for shape (None when the run has none)."""
    if doc is None:
        return None
    ok = (
        isinstance(doc, dict)
        and isinstance(doc.get("sha256"), str)
        and isinstance(doc.get("files"), dict)
        and isinstance(doc.get("settings"), dict)
        and all(
            isinstance(v, dict)
            and isinstance(v.get("path"), str)
            and "sha256" in v
            and isinstance(v["sha256"], (str, type(None)))
            for v in doc["files"].values()
        )
        and all(isinstance(v, str) for v in doc["settings"].values())
    )
    if not ok:
        raise UsageError(f"{where}: fingerprint: a table of sha256, files and settings (as 'run' writes it)")
    return doc


def manifest_path(run_dir: Path) -> Path:
    return run_dir / RUN_FILE


def write_manifest(run_dir: Path, m: RunManifest) -> None:
    """run.json for ``m`` (a new run gets its fingerprint from trials/runs/fingerprint.py first)."""
    run_dir.mkdir(parents=True, exist_ok=True)
    write_json(manifest_path(run_dir), m.to_json())


def read_manifest(run_dir: Path) -> RunManifest | None:
    """The run's parameters, or None when the directory has no run file."""
    path = manifest_path(run_dir)
    if not path.is_file():
        return None
    try:
        doc = read_json(path)
    except JsonFileError as exc:
        raise UsageError(f"{path}: unreadable run file ({exc})") from None
    return RunManifest.from_json(doc, str(path))
