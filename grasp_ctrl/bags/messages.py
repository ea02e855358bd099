"""Messages as the dicts mcap_ros2's encoder takes (field name -> value), one builder each.

A message of a bag is ``(t_ns, topic, type name, message)``: its time in ns (the bag's log
and publish time, and its header stamp) and where and what it is.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from grasp_ctrl.bags import topics
from grasp_ctrl.bags.types import BIOTAC_HAND, N_ELECTRODES, N_PAC
from grasp_ctrl.config.sensor_layout import BIOTAC

Message = tuple[int, str, str, dict[str, Any]]
Vector = Sequence[float] | np.ndarray  # a point, force or quaternion: a tuple or an array row

_ZERO3 = {"x": 0.0, "y": 0.0, "z": 0.0}
_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def stamp(t_ns: int) -> dict[str, int]:
    """builtin_interfaces/Time; a time before 0 borrows a second (nanosec stays 0..1e9-1)."""
    sec, nanosec = divmod(int(t_ns), 10**9)
    return {"sec": sec, "nanosec": nanosec}


def header(t_ns: int, frame_id: str = "") -> dict[str, Any]:
    return {"stamp": stamp(t_ns), "frame_id": frame_id}


def vector3(v: Vector) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def quaternion(q_xyzw: Vector) -> dict[str, float]:
    return {"x": float(q_xyzw[0]), "y": float(q_xyzw[1]), "z": float(q_xyzw[2]), "w": float(q_xyzw[3])}


def joint_state(t_ns: int, names: list[str], position: list[float], effort: list[float]) -> dict[str, Any]:
    return {"header": header(t_ns), "name": names, "position": position, "velocity": [], "effort": effort}


def wrench_stamped(t_ns: int, frame_id: str, f: Vector) -> dict[str, Any]:
    """A force with no torque (the estimators give the force on the skin only)."""
    return {"header": header(t_ns, frame_id), "wrench": {"force": vector3(f), "torque": _ZERO3}}


def string(text: str) -> dict[str, Any]:
    return {"data": text}


def pose_stamped(t_ns: int, frame_id: str, p: Vector) -> dict[str, Any]:
    return {"header": header(t_ns, frame_id), "pose": {"position": vector3(p), "orientation": _IDENTITY}}


def transform(t_ns: int, parent: str, child: str, p: Vector, q_xyzw: Vector) -> dict[str, Any]:
    return {
        "header": header(t_ns, parent),
        "child_frame_id": child,
        "transform": {"translation": vector3(p), "rotation": quaternion(q_xyzw)},
    }


def biotac_data(serial: str, position: int, values: np.ndarray) -> dict[str, Any]:
    """One fingertip's frame (44 raw counts in BioTac order) as a ``BioTacData``."""
    v = [int(x) for x in values]
    return {
        "bt_serial": serial,
        "bt_position": int(position),
        "tdc_data": v[BIOTAC.tdc],
        "tac_data": v[BIOTAC.tac],
        "pdc_data": v[BIOTAC.pdc],
        "pac_data": v[BIOTAC.pac],
        "electrode_data": v[BIOTAC.electrodes],
    }


def biotac_hand(t_ns: int, hand_id: str, data: list[dict[str, Any]]) -> dict[str, Any]:
    """``BioTacHand``: its frames sampled at ``t_ns`` (the channel offsets are not known: 0)."""
    return {
        "header": header(t_ns),
        "hand_id": hand_id,
        "bt_data": data,
        "bt_time": {
            "frame_start_time": stamp(t_ns),
            "frame_end_time": stamp(t_ns),
            "tdc_ns_offset": 0,
            "tac_ns_offset": 0,
            "pdc_ns_offset": 0,
            "pac_ns_offset": [0] * N_PAC,
            "electrode_ns_offset": [0] * N_ELECTRODES,
        },
    }


def recording_messages(
    t_ns: np.ndarray, finger: np.ndarray, values: np.ndarray, hand_id: str = "", serials: dict[int, str] | None = None
) -> Iterator[Message]:
    """Tactile frames as ``BioTacHand`` messages: consecutive frames received at the same time
    share a message, in their order (so importing the bag gives the frames back in order)."""
    serials = serials or {}
    i, n = 0, len(t_ns)
    while i < n:
        j = i + 1
        while j < n and t_ns[j] == t_ns[i]:
            j += 1
        data = [biotac_data(serials.get(int(finger[k]), ""), int(finger[k]), values[k]) for k in range(i, j)]
        yield int(t_ns[i]), topics.BIOTAC, BIOTAC_HAND, biotac_hand(int(t_ns[i]), hand_id, data)
        i = j
