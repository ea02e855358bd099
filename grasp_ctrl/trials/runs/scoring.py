"""Score a run directory from its per-trial records (``score``, ``compare``)."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.json_limits import JsonFileError, read_json
from grasp_ctrl.files.storage import NON_FINITE_KEY, SUMMARY_FILE, finite_json
from grasp_ctrl.trials.runs.manifest import RunManifest, read_manifest
from grasp_ctrl.trials.runs.records import LoadedRecords, canonical_order, load_records
from grasp_ctrl.trials.runs.summary import summarize
from grasp_ctrl.trials.runs.summary_flags import rescored_flags


@dataclass
class Scored:
    run_dir: Path
    summary: dict[str, Any]
    records: list[dict[str, Any]]
    problems: list[tuple[Path, str]] = field(default_factory=list)
    manifest: RunManifest | None = None
    live: dict[str, Any] | None = None  # summary.json as the run wrote it, if readable

    @property
    def policies(self) -> list[str] | None:
        return self.manifest.policies if self.manifest else None

    @property
    def objects(self) -> list[str] | None:
        return self.manifest.object_names if self.manifest else None

    @property
    def expected(self) -> int | None:
        return self.manifest.total if self.manifest else None


def _read_live(run_dir: Path) -> dict[str, Any] | None:
    try:
        doc = read_json(run_dir / SUMMARY_FILE)
    except JsonFileError:
        return None
    return doc if isinstance(doc, dict) else None


def score_run(run_dir: Path) -> Scored:
    if not run_dir.is_dir():
        raise UsageError(f"{run_dir}: no such run directory")
    manifest = read_manifest(run_dir)
    live = _read_live(run_dir)
    loaded = load_records(run_dir)
    if manifest is not None:
        backend, hand, seed = manifest.backend, manifest.hand, manifest.seed
    elif live is not None and {"backend", "hand", "seed"} <= live.keys():
        backend, hand, seed = live["backend"], live["hand"], live["seed"]
    else:
        raise UsageError(f"{run_dir}: neither run.json nor summary.json says which run this is")
    if manifest is not None:
        loaded = only_planned(loaded, manifest, run_dir)
    if not loaded.records:
        where = f" ({len(loaded.problems)} unusable)" if loaded.problems else ""
        raise UsageError(f"{run_dir}: no usable trial records{where}")
    records = canonical_order(
        loaded.records, manifest.policies if manifest else None, manifest.object_names if manifest else None
    )
    summary = rescored_flags(summarize(records, str(run_dir), backend, hand, seed), live)
    return Scored(run_dir, summary, records, loaded.problems, manifest, live)


def only_planned(loaded: LoadedRecords, manifest: RunManifest, run_dir: Path) -> LoadedRecords:
    """The records of the run's plan; the others move to ``problems`` with the reason."""
    from grasp_ctrl.files.storage import TRIALS_DIR, safe_name
    from grasp_ctrl.trials.runs.planned import run_fingerprints, why_unplanned

    known = run_fingerprints(manifest)
    out = LoadedRecords(problems=list(loaded.problems))
    for rec in loaded.records:
        why = why_unplanned(rec, manifest, known)
        if why is None:
            out.records.append(rec)
        else:
            path = run_dir / TRIALS_DIR / safe_name(rec["policy"]) / rec["object"] / f"trial_{rec['trial']:03d}.json"
            out.problems.append((path, f"not a planned trial of this run ({why}); not counted"))
    return out


def report_problems(scored: Scored, stream: TextIO | None = None) -> None:
    """Skipped files by name, missing trials, and any disagreement with summary.json."""
    err = stream or sys.stderr
    for path, why in scored.problems:
        print(f"skipped {path}: {why}", file=err)
    n = len(scored.records)
    if scored.expected is not None and n < scored.expected:
        print(
            f"note: {n} of {scored.expected} trials have usable records "
            f"(finish with: grasp-ctrl run --resume {scored.run_dir})",
            file=err,
        )
    if scored.live is not None and _comparable(scored.live) != _comparable(scored.summary):
        print(
            f"note: differs from the run's own {scored.run_dir / SUMMARY_FILE} "
            "(records changed, were skipped, or the run did not finish)",
            file=err,
        )


def _comparable(summary: dict[str, Any]) -> dict[str, Any]:
    # as summary.json holds it: non-finite numbers written as null (files/storage.py)
    clean, _ = finite_json(summary)
    return {k: v for k, v in clean.items() if k not in ("run_dir", NON_FINITE_KEY)}
