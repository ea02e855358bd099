"""Messages into one MCAP file, ROS 2 profile, CDR encoded (mcap_ros2's writer).

Each type's schema is its ``.msg`` text with its dependencies as rosbags generates it from
its type store (``types.typestore``), so a reader that knows none of the types (Foxglove,
``ros2 bag play``, rosbags) decodes every message from the file alone.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from grasp_ctrl.bags.messages import Message
from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import destination, output_file

SUFFIX = ".mcap"


def check_bag_path(path: Path, flag: str) -> None:
    """A file destination must end in .mcap (a stream takes the bytes whatever its name)."""
    if path.suffix.lower() != SUFFIX and not destination(path, flag).is_stream:
        raise UsageError(f"{flag} {path}: a bag is written as an {SUFFIX} file")


def write_bag(path: Path, msgs: Iterable[Message], metadata: dict[str, str] | None = None) -> Counter[str]:
    """The messages at ``path`` (through a temporary file: a stream gets the bytes, a file is
    replaced only when the bag is whole); returns the number of messages per topic."""
    from mcap_ros2.writer import Writer

    from grasp_ctrl.bags.types import msgdef, typestore

    store = typestore()
    counts: Counter[str] = Counter()
    with output_file(path) as tmp, tmp.open("wb") as fh:
        writer = Writer(fh)
        schemas: dict[str, Any] = {}
        sequence: Counter[str] = Counter()
        for t_ns, topic, typename, message in msgs:
            if t_ns < 0:  # MCAP times are unsigned
                raise UsageError(f"{path}: a message at {t_ns / 1e9:g} s; a bag's clock starts at 0 s")
            schema = schemas.get(typename)
            if schema is None:
                schema = schemas[typename] = writer.register_msgdef(typename, msgdef(store, typename))
            writer.write_message(
                topic, schema, message, log_time=t_ns, publish_time=t_ns, sequence=sequence[topic] % 2**32
            )
            sequence[topic] += 1
            counts[topic] += 1
        if metadata and hasattr(writer, "add_metadata"):  # mcap-ros2-support 0.6 and later
            writer.add_metadata("grasp_ctrl", metadata)
        writer.finish()
    return counts
