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
from grasp_ctrl.sim.variation import Variation
from grasp_ctrl.sim.world_api import World

WorldFactory = Callable[[HandConfig, ObjectProfile, int, Any], World]
BackendFactory = Callable[[Any, HandConfig], tuple[Any, Any]]


@dataclass(frozen=True)
class SimulatedBackend:
    name: str
    description: str
    make_world: WorldFactory  # (hand, object, seed, params or None) -> World
    make_backends: BackendFactory  # (world, hand) -> (hand backend, sensor backend)
    make_params: Callable[[Variation], Any] | None = None  # the world's params under a variation profile


def _mock() -> SimulatedBackend:
    from grasp_ctrl.sim.backends import MockHand, MockSensors
    from grasp_ctrl.sim.world import MockWorld, WorldParams

    def backends(world: Any, hand: HandConfig) -> tuple[Any, Any]:
        return MockHand(world, hand), MockSensors(world)

    return SimulatedBackend(
        "mock",
        "the hand-written test world (fast; holds the object still sideways)",
        MockWorld,
        backends,
        lambda v: WorldParams(variation=v),
    )


def _mujoco() -> SimulatedBackend:
    from grasp_ctrl.sim.mujoco_backends import make_world, mujoco_backends
    from grasp_ctrl.sim.mujoco_world import MuJoCoParams

    return SimulatedBackend(
        "mujoco", "MuJoCo: the reference world", make_world, mujoco_backends, lambda v: MuJoCoParams(variation=v)
    )


_ENTRIES: dict[str, Callable[[], SimulatedBackend]] = {"mujoco": _mujoco, "mock": _mock}

#: The simulated backends' names, the reference world first.
SIMULATED = tuple(_ENTRIES)

#: Worlds for tests and quick checks whose success rates are not results (decision record 0001).
TEST_DOUBLES = frozenset({"mock"})

#: The world behind a backend that is not itself a simulated one: the emulated hand runs on MuJoCo.
WORLD_BEHIND = {"dynamixel-emulated": "mujoco"}


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


def world_params(backend: str, variation: Variation | None) -> Any:
    """The parameters of a trial's world on ``backend`` (a simulated one, or the emulated hand's
    MuJoCo) under ``variation``; None (the world's own defaults) without a variation."""
    if variation is None:
        return None
    entry = simulated_backend(WORLD_BEHIND.get(backend, backend))
    return entry.make_params(variation) if entry.make_params else None
