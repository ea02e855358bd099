"""Read a run's per-trial records back, skipping (and naming) broken files.

A record that cannot be trusted (not JSON, cut short, missing or mistyped
fields, or filed under the wrong policy, object or trial number) is reported
with the reason and left out; it never stops scoring or resuming.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grasp_ctrl.files.json_limits import JsonFileError, read_json
from grasp_ctrl.files.storage import TRIALS_DIR, safe_name

MAX_RECORD_BYTES = 4 * 1024 * 1024

RECORD_NAME = re.compile(r"^trial_(\d{3,})\.json$")
REASON_WORD = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass
class LoadedRecords:
    records: list[dict[str, Any]] = field(default_factory=list)
    problems: list[tuple[Path, str]] = field(default_factory=list)  # (file, why it was skipped)

    def key(self, rec: dict[str, Any]) -> tuple[str, str, int]:
        return (rec["policy"], rec["object"], rec["trial"])

    def by_key(self) -> dict[tuple[str, str, int], dict[str, Any]]:
        return {self.key(r): r for r in self.records}


def check_record(doc: Any, path: Path | None = None) -> str | None:
    """Why ``doc`` is not a usable trial record, or None when it is."""
    if not isinstance(doc, dict):
        return "not a JSON object"
    for key, kind in (("policy", str), ("object", str), ("trial", int), ("seed", int), ("success", bool)):
        if key not in doc:
            return f"missing field {key!r}"
        value = doc[key]
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            return f"field {key!r} is not a {kind.__name__}"
    reason = doc.get("reason")
    if doc["success"]:
        if reason is not None:
            return "a successful trial with a failure reason"
    elif not (isinstance(reason, str) and REASON_WORD.match(reason)):
        return "a failed trial without a snake_case failure reason"
    if path is not None:
        m = RECORD_NAME.match(path.name)
        if not m or int(m.group(1)) != doc["trial"]:
            return f"file name does not match trial {doc['trial']}"
        if path.parent.name != doc["object"] or path.parent.parent.name != safe_name(doc["policy"]):
            return f"filed under the wrong policy/object (record says {doc['policy']}/{doc['object']})"
    return None


def read_record(path: Path) -> tuple[dict[str, Any] | None, str | None]:
    """(record, None) or (None, why it is unusable)."""
    try:
        doc = read_json(path, MAX_RECORD_BYTES)
    except JsonFileError as exc:
        return None, str(exc)
    why = check_record(doc, path)
    return (None, why) if why else (doc, None)


def record_files(run_dir: Path) -> list[Path]:
    root = run_dir / TRIALS_DIR
    if not root.is_dir():
        return []
    return sorted(p for p in root.glob("*/*/trial_*.json") if RECORD_NAME.match(p.name))


def load_records(run_dir: Path) -> LoadedRecords:
    out = LoadedRecords()
    seen: dict[tuple[str, str, int], Path] = {}
    for path in record_files(run_dir):
        rec, why = read_record(path)
        if rec is None:
            out.problems.append((path, why or "unusable"))
            continue
        key = out.key(rec)
        if key in seen:  # two policy specs that map to the same directory name
            out.problems.append((path, f"duplicate of {seen[key]}"))
            continue
        seen[key] = path
        out.records.append(rec)
    return out


def canonical_order(
    records: list[dict[str, Any]], policies: list[str] | None = None, objects: list[str] | None = None
) -> list[dict[str, Any]]:
    """Policy, then object, then trial: the order of the run's parameters where known."""
    pol = {p: i for i, p in enumerate(policies or [])}
    obj = {o: i for i, o in enumerate(objects or [])}
    return sorted(
        records,
        key=lambda r: (
            pol.get(r["policy"], len(pol)),
            r["policy"],
            obj.get(r["object"], len(obj)),
            r["object"],
            r["trial"],
        ),
    )
