"""The run summary (docs/design.md 5.2) from per-trial records.

Trials of a realtime dry run (``run --emulate --realtime``) carry their loop's figures under
``timings.loop``; the summary gives each object those of its trials together (``loop``:
ticks and deadline misses summed, cycle-time p50 the median of the trials' p50, p90/p99/max
the worst trial's) and the table prints them under the success rates. A hand whose host runs a
joint PD loop (the Allegro on CAN) adds that loop's periods (``pd_loop``: periods and missed
periods summed, period p50 the median of the trials', p90/p99/max the worst trial's).
"""

from __future__ import annotations

import math
import statistics
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping
from typing import Any


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _loop_of(record: Mapping[str, Any]) -> Mapping[str, Any] | None:
    """A record's ``timings.loop`` when it is well formed (a hand-edited one is left out)."""
    timings = record.get("timings")
    loop = timings.get("loop") if isinstance(timings, Mapping) else None
    if not isinstance(loop, Mapping):
        return None
    cycle = loop.get("cycle_ms")
    ok = (
        isinstance(loop.get("ticks"), int)
        and isinstance(loop.get("deadline_misses"), int)
        and isinstance(cycle, Mapping)
        and all(_number(cycle.get(k)) for k in ("p50", "p90", "p99", "max"))
    )
    return loop if ok else None


def loop_summary(trials: Iterable[Mapping[str, Any]]) -> dict[str, Any] | None:
    """The wall-clock loop figures of one object's trials together; None when none has them."""
    loops = [lp for lp in (_loop_of(t) for t in trials) if lp is not None]
    if not loops:
        return None
    cycles = [lp["cycle_ms"] for lp in loops]
    out: dict[str, Any] = {
        "trials": len(loops),
        "ticks": sum(lp["ticks"] for lp in loops),
        "deadline_misses": sum(lp["deadline_misses"] for lp in loops),
        "cycle_ms": {
            "p50": round(statistics.median(c["p50"] for c in cycles), 3),
            "p90": max(c["p90"] for c in cycles),
            "p99": max(c["p99"] for c in cycles),
            "max": max(c["max"] for c in cycles),
        },
    }
    for key in ("period_ms", "latency_timer_ms", "baud"):
        values = {lp.get(key) for lp in loops if _number(lp.get(key))}
        if len(values) == 1:
            out[key] = values.pop()
    pd = pd_loop_summary(loops)
    if pd is not None:
        out["pd_loop"] = pd
    return out


def _pd_loop_of(loop: Mapping[str, Any]) -> Mapping[str, Any] | None:
    """A trial's ``timings.loop.pd_loop`` when it is well formed."""
    pd = loop.get("pd_loop")
    if not isinstance(pd, Mapping):
        return None
    period = pd.get("period_ms")
    ok = (
        isinstance(pd.get("periods"), int)
        and isinstance(pd.get("missed_periods"), int)
        and isinstance(period, Mapping)
        and all(_number(period.get(k)) for k in ("p50", "p90", "p99", "max"))
    )
    return pd if ok else None


def pd_loop_summary(loops: Iterable[Mapping[str, Any]]) -> dict[str, Any] | None:
    """The host PD loop's periods of one object's trials together; None when none has them."""
    pds = [pd for pd in (_pd_loop_of(lp) for lp in loops) if pd is not None]
    if not pds:
        return None
    periods = [pd["period_ms"] for pd in pds]
    out: dict[str, Any] = {
        "periods": sum(pd["periods"] for pd in pds),
        "missed_periods": sum(pd["missed_periods"] for pd in pds),
        "period_ms": {
            "p50": round(statistics.median(p["p50"] for p in periods), 3),
            "p90": max(p["p90"] for p in periods),
            "p99": max(p["p99"] for p in periods),
            "max": max(p["max"] for p in periods),
        },
    }
    for key in ("rate_hz", "budget_ms"):
        values = {pd.get(key) for pd in pds if _number(pd.get(key))}
        if len(values) == 1:
            out[key] = values.pop()
    return out


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
            loop = loop_summary(trials)
            if loop is not None:
                obj_out[obj]["loop"] = loop
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
    lines.extend(format_loops(summary))
    return "\n".join(lines)


def format_loops(summary: Mapping[str, Any]) -> list[str]:
    """The wall-clock loop lines of a realtime dry run (none for other runs)."""
    rows = []
    for p, entry in summary["policies"].items():
        for o, e in entry["objects"].items():
            loop = e.get("loop")
            if not isinstance(loop, Mapping):
                continue
            c = loop["cycle_ms"]
            timer = f", latency timer {loop['latency_timer_ms']:g} ms" if "latency_timer_ms" in loop else ""
            rows.append(
                f"  {p} / {o}: cycle p50 {c['p50']:.1f} ms, p99 {c['p99']:.1f} ms, max {c['max']:.1f} ms; "
                f"deadline misses {loop['deadline_misses']} of {loop['ticks']} ticks{timer}"
            )
            pd = loop.get("pd_loop")
            if isinstance(pd, Mapping):
                q = pd["period_ms"]
                budget = f" (budget {pd['budget_ms']:.1f} ms)" if _number(pd.get("budget_ms")) else ""
                rows.append(
                    f"  {p} / {o}: PD loop period p50 {q['p50']:.2f} ms, p99 {q['p99']:.2f} ms, "
                    f"max {q['max']:.1f} ms{budget}; missed {pd['missed_periods']} of {pd['periods']} periods"
                )
    if not rows:
        return []
    period = next(
        (
            e["loop"].get("period_ms")
            for p in summary["policies"].values()
            for e in p["objects"].values()
            if "loop" in e
        ),
        None,
    )
    budget = f", {period:g} ms budget" if isinstance(period, (int, float)) else ""
    return [f"wall-clock loop (realtime dry run{budget}):", *rows]
