"""The simulated backends by name: ``--backend mujoco`` (the reference world) and ``--backend mock``.

Each entry builds a world (sim/world_api.World) for one trial and the hand and sensor backends
over it; the trial code asks this registry instead of comparing backend names. MuJoCo is
imported only when its entry is used.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.errors import UsageError
from grasp_ctrl.sim.world_api import World

WorldFactory = Callable[[HandConfig, ObjectProfile, int, Any], World]
BackendFactory = Callable[[Any, HandConfig], tuple[Any, Any]]


@dataclass(frozen=True)
class SimulatedBackend:
    name: str
    description: str
    make_world: WorldFactory  # (hand, object, seed, params or None) -> World
    make_backends: BackendFactory  # (world, hand) -> (hand backend, sensor backend)


def _mock() -> SimulatedBackend:
    from grasp_ctrl.sim.backends import MockHand, MockSensors
    from grasp_ctrl.sim.world import MockWorld

    def backends(world: Any, hand: HandConfig) -> tuple[Any, Any]:
        return MockHand(world, hand), MockSensors(world)

    return SimulatedBackend(
        "mock", "the hand-written test world (fast; holds the object still sideways)", MockWorld, backends
    )


def _mujoco() -> SimulatedBackend:
    from grasp_ctrl.sim.mujoco_backends import make_world, mujoco_backends

    return SimulatedBackend("mujoco", "MuJoCo: the reference world", make_world, mujoco_backends)


_ENTRIES: dict[str, Callable[[], SimulatedBackend]] = {"mujoco": _mujoco, "mock": _mock}

#: The simulated backends' names, the reference world first.
SIMULATED = tuple(_ENTRIES)

#: Worlds for tests and quick checks whose success rates are not results (decision record 0001).
TEST_DOUBLES = frozenset({"mock"})


def is_simulated(name: str) -> bool:
    return name in _ENTRIES


def is_test_double(name: object) -> bool:
    return name in TEST_DOUBLES


def simulated_backend(name: str) -> SimulatedBackend:
    """The entry for ``name``, or a one-line error naming the simulated backends."""
    try:
        entry = _ENTRIES[name]
    except KeyError:
        raise UsageError(f"--backend {name!r}: not a simulated backend (one of {', '.join(SIMULATED)})") from None
    return entry()
