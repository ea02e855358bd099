"""The Allegro Hand v4 on CAN: its frames (protocol.py), the bus (bus.py, python-can: the ``can``
extra), the host's joint PD loop (pd_loop.py), in its own process (pd_process.py, child.py) or a
thread, and the hand backend (hand.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from grasp_ctrl.hardware.allegro.hand import AllegroCANHand

__all__ = ["AllegroCANHand"]


def __getattr__(name: str) -> Any:
    # Imported on first use: the PD process imports this package's loop, not the backend's
    # goal limiter (and its compiled kernels).
    if name == "AllegroCANHand":
        from grasp_ctrl.hardware.allegro.hand import AllegroCANHand

        return AllegroCANHand
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
