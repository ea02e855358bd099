"""Which records belong to a run's plan: ``score``, ``compare`` and ``resume`` count only these.

A record is planned when its policy and object are in ``run.json``, its trial index
is below ``trials``, its seed is the one the plan gives that trial, and (when it
carries one) its fingerprint is one the run ran with.
"""

from __future__ import annotations

from typing import Any


def run_fingerprints(manifest: Any) -> set[str]:
    """Every fingerprint the run's trials may carry: the current one and those before a --force."""
    out = set()
    if manifest.fingerprint is not None:
        out.add(manifest.fingerprint["sha256"])
    for f in manifest.forced:
        out.update(v for v in (f.get("from"), f.get("to")) if isinstance(v, str))
    return out


def why_unplanned(rec: dict[str, Any], manifest: Any, fingerprints: set[str] | None = None) -> str | None:
    """Why ``rec`` is not a trial of ``manifest``'s plan, or None when it is."""
    from grasp_ctrl.trials.episode.runner import trial_seed

    if rec["policy"] not in manifest.policies:
        return f"policy {rec['policy']!r} is not one of the run's ({', '.join(manifest.policies)})"
    if rec["object"] not in manifest.object_names:
        return f"object {rec['object']!r} is not one of the run's ({', '.join(manifest.object_names)})"
    if not 0 <= rec["trial"] < manifest.trials:
        return f"trial {rec['trial']} is outside the run's {manifest.trials} trials"
    if rec["seed"] != trial_seed(manifest.seed, rec["object"], rec["trial"]):
        return f"seed {rec['seed']} is not the run's seed for this trial"
    fp = rec.get("fingerprint")
    known = run_fingerprints(manifest) if fingerprints is None else fingerprints
    if fp is not None and not isinstance(fp, str):
        return "its fingerprint is not a SHA-256 text"
    if fp is not None and known and fp not in known:
        return "ran with another fingerprint (other policy, hand or settings files)"
    return None
