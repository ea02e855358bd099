"""The run summary (docs/design.md 5.2) from per-trial records."""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping
from typing import Any


def summarize(records: Iterable[Mapping[str, Any]], run_dir: str, backend: str, hand: str, seed: int) -> dict[str, Any]:
    """``records``: dicts with at least ``policy``, ``object``, ``success``, ``reason``."""
    per: dict[str, dict[str, list[Mapping[str, Any]]]] = defaultdict(lambda: defaultdict(list))
    for r in records:
        per[r["policy"]][r["object"]].append(r)
    policies: dict[str, Any] = {}
    for policy, objects in per.items():
        obj_out: dict[str, Any] = {}
        total = succ = 0
        for obj, trials in objects.items():
            n = len(trials)
            s = sum(1 for t in trials if t["success"])
            failures = Counter(t["reason"] for t in trials if not t["success"])
            obj_out[obj] = {
                "trials": n,
                "successes": s,
                "success_rate": s / n if n else 0.0,
                "failures": dict(sorted(failures.items())),
            }
            total += n
            succ += s
        policies[policy] = {
            "objects": obj_out,
            "overall": {"trials": total, "successes": succ, "success_rate": succ / total if total else 0.0},
        }
    return {"run_dir": run_dir, "backend": backend, "hand": hand, "seed": seed, "policies": policies}


def format_table(summary: Mapping[str, Any]) -> str:
    """Per-object success table: one column per policy, plus the overall row."""
    policies = list(summary["policies"])
    objects: list[str] = []
    for p in policies:
        for o in summary["policies"][p]["objects"]:
            if o not in objects:
                objects.append(o)
    width = max([len(o) for o in objects] + [7])
    cols = [max(len(p), 14) for p in policies]
    lines = [f"{'object':{width}s}  " + "  ".join(f"{p:>{c}s}" for p, c in zip(policies, cols))]
    for o in objects:
        cells = []
        for p, c in zip(policies, cols):
            e = summary["policies"][p]["objects"].get(o)
            cells.append(
                f"{'-':>{c}s}"
                if e is None
                else f"{e['successes']}/{e['trials']} {100 * e['success_rate']:5.1f}%".rjust(c)
            )
        lines.append(f"{o:{width}s}  " + "  ".join(cells))
    cells = []
    for p, c in zip(policies, cols):
        e = summary["policies"][p]["overall"]
        cells.append(f"{e['successes']}/{e['trials']} {100 * e['success_rate']:5.1f}%".rjust(c))
    lines.append(f"{'all':{width}s}  " + "  ".join(cells))
    failures = []
    for p in policies:
        for o, e in summary["policies"][p]["objects"].items():
            if e["failures"]:
                why = ", ".join(f"{k} x{v}" for k, v in e["failures"].items())
                failures.append(f"  {p} / {o}: {why}")
    if failures:
        lines.append("failures:")
        lines.extend(failures)
    return "\n".join(lines)
