"""A run's fingerprint: the SHA-256 of everything that decides its trials.

``run.json`` holds it under ``fingerprint``::

    {"sha256": "...",                                    # of all below: the run's one identity
     "files": {"hand": {"path": ..., "sha256": ...},     # the hand file
               "object_file": {...},                     # the object file the profiles came from
               "policy mlp_mock": {...},                  # each policy's JSON ...
               "policy icra19_official model": {...}},    # ... and its model file(s)
     "settings": {"seed": "...", "objects.lego": "...", "settings": "...", ...}}   # run.json's plan, per key

Every trial record carries the ``sha256`` it ran with. ``run --resume`` computes
the fingerprint again from the files on disk and ``run.json``'s plan and refuses
to mix experiments when anything differs, naming what (``--force-resume`` accepts it and
is recorded in ``run.json`` under ``forced``).
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import Any

from grasp_ctrl.errors import GraspCtrlError, UsageError
from grasp_ctrl.files.storage import file_sha256
from grasp_ctrl.trials.runs.manifest import write_manifest

PLAN_KEYS = ("backend", "hand", "seed", "trials", "policies", "tick_logs", "settings")
# Plan keys hashed only when they differ from what every run drew before they existed, so that
# such a run resumes with its fingerprint: the variation profile (nominal; null on the real hand)
# and the wall-clock dry run (false).
OPTIONAL_PLAN_KEYS = ("variation", "realtime")
RECORD_KEY = "fingerprint"


def sha256_json(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True, allow_nan=True).encode()).hexdigest()


def policy_files(spec: str) -> list[tuple[str, Path]]:
    """(role, file) for every file a policy spec loads: its JSON, model file, a calibrated
    policy's base policy and the base's files. Oracles have none (the spec says it all)."""
    from grasp_ctrl.estimators.calibrated import _base_path
    from grasp_ctrl.estimators.calibrated import policy_files as files_of
    from grasp_ctrl.estimators.registry import read_metadata, resolve_policy_path
    from grasp_ctrl.sim.oracle import is_oracle

    if is_oracle(spec):
        return []
    json_path = resolve_policy_path(spec)
    meta = read_metadata(json_path)
    out = [(f"policy {spec}" if f == json_path else f"policy {spec} {f.name}", f) for f in files_of(json_path, meta)]
    if meta.get("kind") == "calibrated":
        base = _base_path(meta, json_path)
        out += [(f"policy {spec} base {f.name}", f) for f in files_of(base, read_metadata(base))]
    return out


def _entry(path: Path) -> dict[str, Any]:
    p = Path(path)
    try:
        digest: str | None = file_sha256(p)
    except OSError:
        digest = None  # gone or unreadable: differs from any recorded hash
    return {"path": str(p.resolve()), "sha256": digest}


def settings_digests(plan: dict[str, Any]) -> dict[str, str]:
    """One hash per plan key of run.json (each object on its own), so a change is named."""
    out = {k: sha256_json(plan.get(k)) for k in PLAN_KEYS}
    from grasp_ctrl.sim.variation import NOMINAL

    variation = plan.get("variation")
    if variation is not None and variation != NOMINAL.to_json():
        out["variation"] = sha256_json(variation)
    if plan.get("realtime"):
        out["realtime"] = sha256_json(plan["realtime"])
    for obj in plan.get("objects") or []:
        name = obj.get("name") if isinstance(obj, dict) else None
        out[f"objects.{name}"] = sha256_json(obj)
    return out


def hand_entry(manifest: Any) -> dict[str, Any]:
    """The fingerprint's entry of the run's hand file as it is now (the default hand file when
    run.json names none, as a run started through the Python API)."""
    from grasp_ctrl.files.paths import default_hand_file

    return _entry(Path(manifest.hand_file or default_hand_file()))


def compute(manifest: Any) -> dict[str, Any]:
    """The fingerprint of ``manifest`` (a RunManifest) with the files as they are now."""
    files: dict[str, dict[str, Any]] = {"hand": hand_entry(manifest)}
    if manifest.object_file:
        files["object_file"] = _entry(Path(manifest.object_file))
    for spec in manifest.policies:
        try:
            found = policy_files(spec)
        except GraspCtrlError:
            found = []
            files[f"policy {spec}"] = {"path": spec, "sha256": None}
        for role, path in found:
            files[role] = _entry(path)
    plan = {k: v for k, v in manifest.to_json().items() if k in (*PLAN_KEYS, *OPTIONAL_PLAN_KEYS, "objects")}
    settings = settings_digests(plan)
    digest = sha256_json({"files": {k: v["sha256"] for k, v in files.items()}, "settings": settings})
    return {"sha256": digest, "files": files, "settings": settings}


def differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """What changed between two fingerprints, in words (empty when they are equal)."""
    out = []
    old_files, new_files = old.get("files", {}), new.get("files", {})
    for role in sorted(set(old_files) | set(new_files)):
        a, b = old_files.get(role), new_files.get(role)
        if a is None:
            out.append(f"{role} ({b.get('path')}) is new")
        elif b is None or b.get("sha256") is None:
            out.append(f"{role} ({a.get('path')}) is gone")
        elif a.get("sha256") != b.get("sha256"):
            out.append(f"{role} ({b.get('path')}) changed")
    old_set, new_set = old.get("settings", {}), new.get("settings", {})
    for key in sorted(set(old_set) | set(new_set)):
        if old_set.get(key) != new_set.get(key):
            out.append(f"run.json {key} changed")
    if not out and old.get("sha256") != new.get("sha256"):
        out.append("run.json fingerprint.sha256 does not match its files and settings")
    return out


def hand_changes(manifest: Any) -> list[str]:
    """How the run's hand file differs from the one its trials ran with, in ``--resume``'s words
    (``hand (PATH) changed``, ``... is gone``); empty when it is the same, or when run.json
    recorded no hash of it (a run from before the hashes)."""
    recorded = ((manifest.fingerprint or {}).get("files") or {}).get("hand")
    if recorded is None and manifest.hand_sha256:
        recorded = {"path": manifest.hand_file, "sha256": manifest.hand_sha256}
    if recorded is None:
        return []
    return differences({"files": {"hand": recorded}}, {"files": {"hand": hand_entry(manifest)}})


def check_resume(manifest: Any, run_file: Path, force: bool) -> bool:
    """Refuse to resume a run whose trials would differ from its first ones.

    Returns True when ``manifest`` was changed (a fingerprint added to a run that had
    none, or ``--force-resume`` recorded) and run.json must be written again."""
    now = compute(manifest)
    old = manifest.fingerprint
    if old is None:  # a run from before fingerprints (or one whose was deleted): its records tell
        others = sorted(record_fingerprints(run_file.parent) - {now["sha256"]})
        if others and not force:
            raise UsageError(
                f"--resume: {run_file} has no fingerprint and {len(others)} fingerprint(s) of its "
                "records differ from its files now (a policy, hand or object file or a setting "
                "changed); start a new run, or add --force-resume to continue anyway (recorded in run.json)"
            )
        if others:
            manifest.forced.append(
                {
                    "at": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                    "changed": ["run.json fingerprint"],
                    "from": others[0],
                    "to": now["sha256"],
                }
            )
        manifest.fingerprint = now
        return True
    changed = differences(old, now)
    if not changed:
        return False
    if not force:
        raise UsageError(
            f"--resume: {'; '.join(changed)} since the run started ({run_file}); the rest of the run "
            "would mix two experiments. Start a new run, or add --force-resume to continue anyway "
            "(recorded in run.json)"
        )
    manifest.forced.append(
        {"at": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "changed": changed, "from": old["sha256"], "to": now["sha256"]}
    )
    manifest.fingerprint = now
    return True


def record_fingerprints(run_dir: Path) -> set[str]:
    """The fingerprints the run's readable records carry."""
    from grasp_ctrl.trials.runs.records import load_records

    return {r[RECORD_KEY] for r in load_records(run_dir).records if isinstance(r.get(RECORD_KEY), str)}


def stamp(record: dict[str, Any], manifest: Any) -> dict[str, Any]:
    """The record with the fingerprint its trial ran with."""
    fp = getattr(manifest, "fingerprint", None)
    if fp is not None:
        record[RECORD_KEY] = fp["sha256"]
    return record


def sync_manifest(run_dir: Path, plan: Any, existing: Any) -> None:
    """Write run.json for a new run (with its fingerprint), or again when a resume changed it
    (``--force-resume`` recorded, or a fingerprint added to an older run). A resume through the
    Python API without a manifest takes the run's own fingerprint."""
    if existing is None:
        _write_with_fingerprint(run_dir, plan)
        return
    if plan.fingerprint is None:
        plan.fingerprint, plan.forced = existing.fingerprint, list(existing.forced)
        if plan.fingerprint is not None:
            return
    if plan.to_json() != existing.to_json():
        _write_with_fingerprint(run_dir, plan)


def _write_with_fingerprint(run_dir: Path, plan: Any) -> None:
    if plan.fingerprint is None:
        plan.fingerprint = compute(plan)
    write_manifest(run_dir, plan)
