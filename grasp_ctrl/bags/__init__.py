"""ROS bags in and out (the ros extra: mcap, mcap-ros2-support, rosbags).

- ``export-bag`` / ``run --mcap``: a trial (or a tactile recording) as a ROS 2 bag in one
  MCAP file, CDR-encoded standard messages (``export``, ``trial_messages``, ``writer``);
- ``import-bag``: ``biotac_sensors/BioTacHand`` messages of a ROS 1 or ROS 2 bag into the
  tactile recording format of ``sensors --record``, with force labels from a wrench topic
  (``reader``, ``import_``, ``labels``, ``recording``).

The message definitions registered for the BioTac driver's messages are in ``types``; the
topics and frames of a trial bag in ``topics`` (docs/ros_bags.md). The libraries are imported
only inside the functions that need them, so the rest of the package runs without the extra.
"""

from __future__ import annotations

from grasp_ctrl.errors import UsageError

INSTALL_HINT = "pip install -e '.[ros]'"


def require_ros() -> None:
    """One line naming the extra when a library of it is missing."""
    missing = []
    for module, dist in (("mcap", "mcap"), ("mcap_ros2", "mcap-ros2-support"), ("rosbags", "rosbags")):
        try:
            __import__(module)
        except ImportError:
            missing.append(dist)
    if missing:
        raise UsageError(f"ROS bags need {', '.join(missing)}: {INSTALL_HINT}")
