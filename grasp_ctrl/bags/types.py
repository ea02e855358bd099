"""Message types of the bags: the standard ROS 2 ones and the BioTac driver's own.

The BioTac messages are those of the ``biotac_sensors`` package of the BioTac ROS driver
(``biotac_pub`` publishes ``BioTacHand`` on ``biotac_pub``), field for field, so tools written
for the driver read them. In ROS 1 syntax (``Header`` and ``time``; the definitions below use
the ROS 2 spellings ``std_msgs/Header`` and ``builtin_interfaces/Time``, which is what a
ROS 2 port of the package declares)::

    biotac_sensors/BioTacHand:  Header header
                                string hand_id
                                biotac_sensors/BioTacData[] bt_data
                                biotac_sensors/BioTacTime bt_time
    biotac_sensors/BioTacData:  string bt_serial
                                uint16 bt_position
                                uint16 tdc_data
                                uint16 tac_data
                                uint16 pdc_data
                                uint16[22] pac_data
                                uint16[19] electrode_data
    biotac_sensors/BioTacTime:  time frame_start_time
                                time frame_end_time
                                uint32 tdc_ns_offset
                                uint32 tac_ns_offset
                                uint32 pdc_ns_offset
                                uint32[22] pac_ns_offset
                                uint32[19] electrode_ns_offset

Registered in a ROS 1 type store these give the driver's MD5 sum
(``BIOTAC_HAND_ROS1_MD5``), which a ROS 1 tool checks before it reads a message.
Reading a bag, the bag's own definition wins where it carries one (ROS 1 bags and MCAP
files do), so a variant (unbounded arrays, no ``bt_time``) reads as well.
"""

from __future__ import annotations

from typing import Any

BIOTAC_HAND = "biotac_sensors/msg/BioTacHand"
BIOTAC_DATA = "biotac_sensors/msg/BioTacData"
BIOTAC_TIME = "biotac_sensors/msg/BioTacTime"
BIOTAC_HAND_ROS1_MD5 = "d96f900cbfb096d61de125081e11dcab"
N_PAC = 22
N_ELECTRODES = 19

JOINT_STATE = "sensor_msgs/msg/JointState"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
WRENCH = "geometry_msgs/msg/Wrench"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
STRING = "std_msgs/msg/String"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"

BIOTAC_MSGS: dict[str, str] = {
    BIOTAC_HAND: (
        "std_msgs/Header header\n"
        "string hand_id\n"
        "biotac_sensors/BioTacData[] bt_data\n"
        "biotac_sensors/BioTacTime bt_time\n"
    ),
    BIOTAC_DATA: (
        "string bt_serial\n"
        "uint16 bt_position\n"
        "uint16 tdc_data\n"
        "uint16 tac_data\n"
        "uint16 pdc_data\n"
        f"uint16[{N_PAC}] pac_data\n"
        f"uint16[{N_ELECTRODES}] electrode_data\n"
    ),
    BIOTAC_TIME: (
        "builtin_interfaces/Time frame_start_time\n"
        "builtin_interfaces/Time frame_end_time\n"
        "uint32 tdc_ns_offset\n"
        "uint32 tac_ns_offset\n"
        "uint32 pdc_ns_offset\n"
        f"uint32[{N_PAC}] pac_ns_offset\n"
        f"uint32[{N_ELECTRODES}] electrode_ns_offset\n"
    ),
}


def biotac_types() -> dict[str, Any]:
    """The BioTac message types as rosbags field definitions (``Typestore.register`` takes them)."""
    from rosbags.typesys import get_types_from_msg

    out: dict[str, Any] = {}
    for name, text in BIOTAC_MSGS.items():
        out.update(get_types_from_msg(text, name))
    return out


def typestore(ros_version: int = 2) -> Any:
    """rosbags' type store of ROS 2 Humble (or ROS 1 Noetic) with the BioTac messages added."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE if ros_version == 2 else Stores.ROS1_NOETIC)
    store.register(biotac_types())
    return store


def add_biotac_types(store: Any) -> None:
    """Registers the BioTac messages in ``store`` where it lacks them (a bag without definitions)."""
    missing = {k: v for k, v in biotac_types().items() if k not in store.fielddefs}
    if missing:
        store.register(missing)


def msgdef(store: Any, name: str) -> str:
    """The ROS 2 ``.msg`` text of ``name`` with its dependencies, as an MCAP ``ros2msg`` schema."""
    text, _ = store.generate_msgdef(name, ros_version=2)
    return text


def short_name(name: str) -> str:
    """``pkg/msg/Type`` -> ``pkg/Type`` (how ROS 1 and people write it)."""
    parts = name.split("/")
    return f"{parts[0]}/{parts[-1]}" if len(parts) == 3 and parts[1] == "msg" else name
