"""The Allegro Hand v4 on CAN: its frames (protocol.py), the bus (bus.py, python-can: the ``can``
extra), the host's joint PD loop (pd_loop.py) and the hand backend (hand.py)."""

from grasp_ctrl.hardware.allegro.hand import AllegroCANHand

__all__ = ["AllegroCANHand"]
