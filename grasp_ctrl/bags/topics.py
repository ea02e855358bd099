"""Topic and frame names of a trial bag (docs/ros_bags.md lists them with their types)."""

from __future__ import annotations

JOINT_STATES = "/joint_states"  # measured joint angles (and currents where logged)
JOINT_GOALS = "/joint_goals"  # the goals the controller sent
CONTROLLER_STATE = "/controller/state"  # every tick
CONTROLLER_TRANSITIONS = "/controller/transitions"  # "SRC -> DST" when the state changes
TRIAL_EVENTS = "/trial/events"  # the world's events (contacts, a fall, a crush)
OBJECT_POSE = "/object/pose"
TF = "/tf"
BIOTAC = "/biotac_pub"  # the BioTac driver's own topic

WORLD_FRAME = "world"  # on the table top, z up
HAND_FRAME = "hand"  # the hand file's hand (palm) frame; the arm translates it, never turns it


def force_topic(finger: str, kind: str) -> str:
    """``/fingertips/FINGER/force_estimated`` or ``.../force_true``."""
    return f"/fingertips/{finger}/force_{kind}"


def sensor_frame(finger: str) -> str:
    """A fingertip's sensor frame (the MuJoCo scene's ``FINGER_sensor`` site)."""
    return f"{finger}_sensor"


def base_frame(finger: str) -> str:
    return f"{finger}_base"


def link_frame(joint: str) -> str:
    """The link a joint turns (after its rotation), named after the joint."""
    return f"{joint}_link"
