"""Reading a user's bag (rosbags): a ROS 1 ``.bag``, a ROS 2 ``.db3`` or ``.mcap`` file, or a
ROS 2 bag folder; the BioTac frames and the wrenches of its topics.

Every problem is one line naming the bag: not a bag, unreadable or truncated, a topic that
is missing or of another type, a message whose fields are not the BioTac driver's.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.bags.types import BIOTAC_HAND, N_ELECTRODES, N_PAC, WRENCH, WRENCH_STAMPED, short_name
from grasp_ctrl.config.sensor_layout import BIOTAC, FRAME_LEN
from grasp_ctrl.errors import UsageError

ROS2_SUFFIXES = (".db3", ".mcap")


@dataclass
class TactileFrames:
    t_ns: np.ndarray  # (n,) int64: the message's header stamp (its bag time where the stamp is 0)
    position: np.ndarray  # (n,) int: bt_position
    values: np.ndarray  # (n, 44) int64 raw counts, BioTac order
    messages: int


@dataclass
class Wrenches:
    t_ns: np.ndarray  # (m,) int64
    f_wrench: np.ndarray  # (m, 3) N, in the frame of the messages (frame_id)
    frame_id: str


def _why(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text and text[0] else type(exc).__name__


def check_bag_file(path: Path) -> None:
    if not path.exists():
        raise UsageError(f"{path}: no such bag")
    if path.is_dir():
        if not (path / "metadata.yaml").is_file():
            raise UsageError(f"{path}: a folder without metadata.yaml, not a ROS 2 bag")
    elif path.suffix.lower() not in (".bag", *ROS2_SUFFIXES):
        raise UsageError(f"{path}: not a bag (a ROS 1 .bag, a ROS 2 .db3 or .mcap file, or a ROS 2 bag folder)")


class Bag:
    """An open bag: ``with Bag(path) as bag: bag.topics ...``."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        check_bag_file(self.path)
        self._stack = contextlib.ExitStack()
        self.reader: Any = None

    def __enter__(self) -> Bag:
        from rosbags.highlevel import AnyReader

        from grasp_ctrl.bags.types import add_biotac_types, typestore

        try:
            self.reader = self._stack.enter_context(AnyReader([self.path], default_typestore=typestore()))
        except Exception as exc:  # rosbags, sqlite, zstd and struct errors of a damaged file
            raise UsageError(f"{self.path}: not a readable bag, truncated or damaged ({_why(exc)})") from None
        add_biotac_types(self.reader.typestore)  # a .db3 without definitions: the driver's
        return self

    def __exit__(self, *exc: object) -> None:
        with contextlib.suppress(Exception):
            self._stack.close()

    @property
    def topics(self) -> dict[str, tuple[str, int]]:
        """Topic -> (message type, message count)."""
        out: dict[str, tuple[str, int]] = {}
        for c in self.reader.connections:
            kind, n = out.get(c.topic, (c.msgtype, 0))
            out[c.topic] = (kind, n + c.msgcount)
        return out

    def _listing(self) -> str:
        shown = [f"{t} ({short_name(k)})" for t, (k, _) in sorted(self.topics.items())]
        return ", ".join(shown[:8]) + (", ..." if len(shown) > 8 else "") if shown else "none"

    def topic(self, name: str | None, types: tuple[str, ...], flag: str) -> str:
        """The topic ``name`` checked to be of one of ``types``; without a name, the only one of them."""
        want = " or ".join(short_name(t) for t in types)
        if name is None:
            found = [t for t, (k, _) in self.topics.items() if k in types]
            if not found:
                raise UsageError(f"{self.path}: no {want} topic (topics: {self._listing()})")
            if len(found) > 1:
                raise UsageError(
                    f"{self.path}: {len(found)} {want} topics ({', '.join(sorted(found))}); choose with {flag}"
                )
            return found[0]
        if name not in self.topics:
            raise UsageError(f"{flag} {name}: not in {self.path} (topics: {self._listing()})")
        kind = self.topics[name][0]
        if kind not in types:
            raise UsageError(f"{flag} {name}: {short_name(kind)} in {self.path}, not {want}")
        return name

    def messages(self, topic: str) -> Iterator[tuple[int, Any]]:
        """(bag time in ns, message) of ``topic`` in time order; a damaged message stops it on one line."""
        conns = [c for c in self.reader.connections if c.topic == topic]
        k = 0
        try:
            for conn, t_ns, raw in self.reader.messages(connections=conns):
                yield int(t_ns), self.reader.deserialize(raw, conn.msgtype)
                k += 1
        except UsageError:
            raise
        except Exception as exc:
            raise UsageError(
                f"{self.path}: {topic}: unreadable after {k} message(s), truncated or damaged ({_why(exc)})"
            ) from None


def _stamp_ns(msg: Any, t_bag: int) -> int:
    header = getattr(msg, "header", None)
    st = getattr(header, "stamp", None)
    if st is None:
        return t_bag
    ns = int(st.sec) * 10**9 + int(st.nanosec)
    return ns if ns else t_bag  # an unset stamp: when the bag got it


def _field(obj: Any, name: str, bag: Bag, topic: str, k: int) -> Any:
    try:
        return getattr(obj, name)
    except AttributeError:
        raise UsageError(
            f"{bag.path}: {topic}: message {k} has no field {name!r} (not the BioTac driver's BioTacHand)"
        ) from None


def read_tactile(bag: Bag, topic: str) -> TactileFrames:
    """Every ``BioTacData`` of the topic's messages, one frame each, in message order."""
    t_out: list[int] = []
    pos: list[int] = []
    rows: list[np.ndarray] = []
    n_msgs = 0
    for k, (t_bag, msg) in enumerate(bag.messages(topic)):
        n_msgs += 1
        t_ns = _stamp_ns(msg, t_bag)
        for j, bt in enumerate(_field(msg, "bt_data", bag, topic, k)):
            where = f"{bag.path}: {topic}: message {k}, bt_data[{j}]"
            electrodes = np.asarray(_field(bt, "electrode_data", bag, topic, k), dtype=np.int64).ravel()
            pac = np.asarray(_field(bt, "pac_data", bag, topic, k), dtype=np.int64).ravel()
            if len(electrodes) != N_ELECTRODES or len(pac) != N_PAC:
                raise UsageError(
                    f"{where}: {len(electrodes)} electrode and {len(pac)} pac values "
                    f"({N_ELECTRODES} and {N_PAC} in a BioTac frame)"
                )
            frame = np.empty(FRAME_LEN, dtype=np.int64)
            frame[BIOTAC.electrodes] = electrodes
            frame[BIOTAC.pac] = pac
            frame[BIOTAC.pdc] = int(_field(bt, "pdc_data", bag, topic, k))
            frame[BIOTAC.tdc] = int(_field(bt, "tdc_data", bag, topic, k))
            frame[BIOTAC.tac] = int(_field(bt, "tac_data", bag, topic, k))
            if frame.max() > BIOTAC.count_max or frame.min() < BIOTAC.count_min:
                raise UsageError(
                    f"{where}: a count of {int(frame.max())}, outside {BIOTAC.count_min}..{BIOTAC.count_max} "
                    "(a BioTac channel is 12-bit)"
                )
            t_out.append(t_ns)
            pos.append(int(_field(bt, "bt_position", bag, topic, k)))
            rows.append(frame)
    values = np.array(rows, dtype=np.int64).reshape(len(rows), FRAME_LEN)
    return TactileFrames(np.array(t_out, dtype=np.int64), np.array(pos, dtype=np.int64), values, n_msgs)


def read_wrenches(bag: Bag, topic: str) -> Wrenches:
    """The forces of a ``WrenchStamped`` (at its stamp) or ``Wrench`` topic (at its bag time)."""
    t_out: list[int] = []
    forces: list[tuple[float, float, float]] = []
    frame_id = ""
    for t_bag, msg in bag.messages(topic):
        wrench = getattr(msg, "wrench", msg)
        f = wrench.force
        t_out.append(_stamp_ns(msg, t_bag))
        forces.append((float(f.x), float(f.y), float(f.z)))
        header = getattr(msg, "header", None)
        frame_id = frame_id or str(getattr(header, "frame_id", "") or "")
    f_arr = np.array(forces, dtype=float).reshape(len(forces), 3)
    if not np.isfinite(f_arr).all():
        bad = int(np.flatnonzero(~np.isfinite(f_arr).all(axis=1))[0])
        raise UsageError(f"{bag.path}: {topic}: message {bad}: a force that is not a finite number")
    return Wrenches(np.array(t_out, dtype=np.int64), f_arr, frame_id)


TACTILE_TYPES = (BIOTAC_HAND,)
WRENCH_TYPES = (WRENCH_STAMPED, WRENCH)
