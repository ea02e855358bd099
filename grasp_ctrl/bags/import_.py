"""BioTac frames of bags as a tactile recording (``import-bag``; the recording: ``recording``).

Each ``BioTacData`` of a ``biotac_sensors/BioTacHand`` message is one row: ``t_recv`` is the
message's header stamp (its bag time where the stamp is 0), ``finger`` its ``bt_position``,
``seq`` the frame's number for that fingertip in the bag, from 0 (BioTacHand carries no
sequence number), then the 44 counts. Several bags are appended in the order given; with a
wrench topic each bag is one trial, named after the bag, and the rows carry force labels
(``labels``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grasp_ctrl.bags import require_ros
from grasp_ctrl.bags.recording import MAX_SEQ, Labels, Recording
from grasp_ctrl.errors import UsageError

DEFAULT_MIN_FORCE_N = 0.2  # a direction label needs this much force (a F/T sensor's noise is below)


@dataclass
class BagSummary:
    path: Path
    topic: str
    frames: int
    positions: list[int]
    t0_s: float
    t1_s: float
    wrench_topic: str | None = None
    wrench_frame: str = ""
    left_out: int = 0  # frames outside the wrench topic's time span

    def line(self) -> str:
        where = ", ".join(str(p) for p in self.positions)
        text = (
            f"{self.path}: {self.frames} frames from {self.topic} (bt_position {where}), "
            f"{self.t0_s:.3f} .. {self.t1_s:.3f} s"
        )
        if self.wrench_topic is not None:
            frame = f" in frame {self.wrench_frame!r}" if self.wrench_frame else ""
            text += f"; labels from {self.wrench_topic}{frame}"
            if self.left_out:
                text += f", {self.left_out} frames outside its time span left out"
        return text


@dataclass
class Imported:
    recording: Recording
    bags: list[BagSummary] = field(default_factory=list)


def trial_id(path: Path) -> str:
    """A bag's trial id: its name without the suffix."""
    name = path.resolve().name if path.is_dir() else path.name
    return name[: -len(path.suffix)] if path.suffix and not path.is_dir() else name


def _seq(position: np.ndarray) -> np.ndarray:
    """Each frame's number among its fingertip's frames, from 0 (wrapping as a uint16)."""
    out = np.empty(len(position), dtype=np.int64)
    counts: dict[int, int] = {}
    for i, p in enumerate(position.tolist()):
        out[i] = counts.get(p, 0) % (MAX_SEQ + 1)
        counts[p] = counts.get(p, 0) + 1
    return out


def import_bag(
    path: Path,
    topic: str | None = None,
    wrench: str | None = None,
    finger: int | None = None,
    min_force_n: float = DEFAULT_MIN_FORCE_N,
) -> tuple[Recording, BagSummary]:
    """One bag's frames (of fingertip ``finger`` only, when given), labelled from ``wrench``."""
    from grasp_ctrl.bags import labels as lab
    from grasp_ctrl.bags.reader import TACTILE_TYPES, WRENCH_TYPES, Bag, read_tactile, read_wrenches

    with Bag(path) as bag:
        tactile_topic = bag.topic(topic, TACTILE_TYPES, "--topic")
        wrench_topic = bag.topic(wrench, WRENCH_TYPES, "--wrench") if wrench is not None else None
        frames = read_tactile(bag, tactile_topic)
        wrenches = read_wrenches(bag, wrench_topic) if wrench_topic is not None else None
    if not len(frames.t_ns):
        raise UsageError(f"{path}: {tactile_topic}: no BioTac frames ({frames.messages} messages)")
    positions = sorted(set(frames.position.tolist()))
    if finger is not None:
        if finger not in positions:
            have = ", ".join(map(str, positions))
            raise UsageError(f"--finger {finger}: no frames of it in {path} (bt_position {have})")
        keep = frames.position == finger
    elif wrench is not None and len(positions) > 1:
        raise UsageError(
            f"--wrench: {path} holds BioTacs at bt_position {', '.join(map(str, positions))}; "
            "name the one the wrench measures with --finger"
        )
    else:
        keep = np.ones(len(frames.t_ns), dtype=bool)
    t_ns, position, values = frames.t_ns[keep], frames.position[keep], frames.values[keep]
    rec = Recording(t_ns, position, _seq(position), values)
    summary = BagSummary(path, tactile_topic, len(rec), sorted(set(position.tolist())), 0.0, 0.0)
    if wrenches is not None:
        lab.check_wrenches(len(wrenches.t_ns), f"{path}: {wrench_topic}")
        f_wrench, inside = lab.force_at(rec.t_ns, wrenches.t_ns, wrenches.f_wrench)
        if not inside.any():
            raise UsageError(
                f"--wrench {wrench_topic}: its messages and the BioTac frames of {path} do not overlap in time"
            )
        rec, f_wrench = rec.subset(inside), f_wrench[inside]
        n_wrench = lab.directions(rec.t_ns, f_wrench, min_force_n)
        if n_wrench is None:
            raise UsageError(
                f"--wrench {wrench_topic}: no force of {min_force_n:g} N or more in {path}; no direction to label "
                "(a lower --min-force?)"
            )
        rec.labels = Labels(np.full(len(rec), trial_id(path), dtype=object), f_wrench, n_wrench)
        summary.wrench_topic, summary.wrench_frame = wrench_topic, wrenches.frame_id
        summary.left_out, summary.frames = int((~inside).sum()), len(rec)
    summary.t0_s, summary.t1_s = int(rec.t_ns.min()) / 10**9, int(rec.t_ns.max()) / 10**9
    return rec, summary


def import_bags(
    paths: Sequence[Path],
    topic: str | None = None,
    wrench: str | None = None,
    finger: int | None = None,
    min_force_n: float = DEFAULT_MIN_FORCE_N,
) -> Imported:
    """The bags' frames appended in order (with labels: one trial per bag)."""
    require_ros()
    if wrench is not None:
        ids = [trial_id(p) for p in paths]
        dup = next((i for i in ids if ids.count(i) > 1), None)
        if dup is not None:
            raise UsageError(f"two bags named {dup!r}: each bag is a trial, named after it; rename one")
    parts = [import_bag(p, topic, wrench, finger, min_force_n) for p in paths]
    recs = [r for r, _ in parts]
    labels = None
    if wrench is not None:
        labels = Labels(
            np.concatenate([r.labels.trial_id for r in recs if r.labels is not None]),
            np.concatenate([r.labels.f_wrench for r in recs if r.labels is not None]),
            np.concatenate([r.labels.n_wrench for r in recs if r.labels is not None]),
        )
    rec = Recording(
        np.concatenate([r.t_ns for r in recs]),
        np.concatenate([r.finger for r in recs]),
        np.concatenate([r.seq for r in recs]),
        np.concatenate([r.values for r in recs]),
        labels,
    )
    return Imported(rec, [s for _, s in parts])
