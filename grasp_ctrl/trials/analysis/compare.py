"""Policy comparison: the paper's Fig. 6 table and paired outcome counts.

Every policy runs the same seeded trials, so trial k of an object is the same
situation for all policies: the paired counts say how often one policy
succeeded where the other failed.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any


def ordered_names(
    summary: Mapping[str, Any], policies: list[str] | None = None, objects: list[str] | None = None
) -> tuple[list[str], list[str]]:
    pols = [p for p in (policies or []) if p in summary["policies"]]
    pols += [p for p in summary["policies"] if p not in pols]
    objs = [o for o in (objects or [])]
    for p in pols:
        for o in summary["policies"][p]["objects"]:
            if o not in objs:
                objs.append(o)
    objs = [o for o in objs if any(o in summary["policies"][p]["objects"] for p in pols)]
    return pols, objs


def success_matrix(summary: Mapping[str, Any], pols: list[str], objs: list[str]) -> list[list[float | None]]:
    """Rows: objects then ``all``; columns: policies; success rate in 0..1 (None: not run)."""
    rows: list[list[float | None]] = []
    for o in objs:
        row: list[float | None] = []
        for p in pols:
            e = summary["policies"][p]["objects"].get(o)
            row.append(None if e is None else float(e["success_rate"]))
        rows.append(row)
    rows.append([float(summary["policies"][p]["overall"]["success_rate"]) for p in pols])
    return rows


def fig6_table(summary: Mapping[str, Any], policies: list[str] | None = None, objects: list[str] | None = None) -> str:
    """Success rate per object per policy, plus ``all`` (the paper's Fig. 6 as text)."""
    pols, objs = ordered_names(summary, policies, objects)
    width = max([len(o) for o in objs] + [len("success rate")])
    cols = [max(len(p), len("100% (10/10)")) for p in pols]
    lines = [f"{'success rate':{width}s}  " + "  ".join(f"{p:>{c}s}" for p, c in zip(pols, cols))]
    for name in objs + ["all"]:
        cells = []
        for p, c in zip(pols, cols):
            e = summary["policies"][p]["overall"] if name == "all" else summary["policies"][p]["objects"].get(name)
            text = "-" if e is None else f"{100 * e['success_rate']:.0f}% ({e['successes']}/{e['trials']})"
            cells.append(text.rjust(c))
        lines.append(f"{name:{width}s}  " + "  ".join(cells))
    return "\n".join(lines)


@dataclass(frozen=True)
class Paired:
    a: str
    b: str
    both_ok: int
    only_a: int
    only_b: int
    both_failed: int

    @property
    def pairs(self) -> int:
        return self.both_ok + self.only_a + self.only_b + self.both_failed


def paired_counts(records: Iterable[Mapping[str, Any]], a: str, b: str) -> Paired:
    """Counts over the (object, trial) pairs that both policies ran."""
    res: dict[str, dict[tuple[str, int], bool]] = {a: {}, b: {}}
    for r in records:
        if r["policy"] in res:
            res[r["policy"]][(r["object"], r["trial"])] = bool(r["success"])
    keys = res[a].keys() & res[b].keys()
    n = {(x, y): 0 for x in (True, False) for y in (True, False)}
    for k in keys:
        n[(res[a][k], res[b][k])] += 1
    return Paired(a, b, n[(True, True)], n[(True, False)], n[(False, True)], n[(False, False)])


def format_paired(p: Paired) -> str:
    return (
        f"{p.a} vs {p.b} over {p.pairs} paired trials: both succeeded {p.both_ok}, "
        f"only {p.a} {p.only_a}, only {p.b} {p.only_b}, both failed {p.both_failed}"
    )
