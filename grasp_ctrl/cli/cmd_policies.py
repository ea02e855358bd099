"""``policies``: list the force-estimator policies with their metadata."""

from __future__ import annotations

import argparse
import json
from typing import Any

from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "policies"
HELP = "list the force-estimator policies (policies/*.json) with their metadata"
ORDER = 60


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", metavar="FILE", help="also write the metadata of all policies as JSON")
    p.add_argument(
        "--check",
        action="store_true",
        help="load each policy against the default hand (catches metadata/model mismatches)",
    )


def _summary(meta: dict[str, Any]) -> str:
    parts = [f"kind={meta.get('kind')}", f"sensor={meta.get('sensor_type')}"]
    out = meta.get("output", {})
    if isinstance(out, dict) and out:
        parts.append(f"output={out.get('units', '?')} in {out.get('frame', '?')} frame")
    parts.append(f"variance={'yes' if meta.get('has_variance') else 'no'}")
    prov = meta.get("provenance")
    if isinstance(prov, dict) and prov.get("source"):
        parts.append(f"from {prov['source']}")
    if meta.get("licence"):
        parts.append(f"licence {meta['licence']}")
    return ", ".join(parts)


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.errors import GraspCtrlError
    from grasp_ctrl.estimators.registry import list_policy_names, load_policy, read_metadata, resolve_policy_path
    from grasp_ctrl.files.paths import default_hand_file

    names = list_policy_names()
    hand = load_hand(default_hand_file()) if args.check else None
    docs = {}
    status = 0
    for name in names:
        try:
            meta = read_metadata(resolve_policy_path(name))
        except GraspCtrlError as exc:
            print(f"{name:28s} unreadable: {exc}")
            status = 2
            continue
        docs[name] = meta
        line = f"{name:28s} {_summary(meta)}"
        if args.check:
            try:
                load_policy(name, hand, 1)
                line += "  [loads]"
            except GraspCtrlError as exc:
                line += f"  [FAILS: {exc}]"
                status = 2
        print(line)
        desc = meta.get("description")
        if desc:
            print(f"{'':28s} {desc}")
    print(f"{'oracle, oracle:scale=K':28s} debugging policies of the mock world (true contact force)")
    if args.json:
        write_output(check_output(args.json, "--json"), json.dumps(docs, indent=2) + "\n")
    return status
