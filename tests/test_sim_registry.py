"""The simulated backends by name (sim/registry.py) and the World protocol (sim/world_api.py)."""

from __future__ import annotations

import pytest

from grasp_ctrl.errors import UsageError
from grasp_ctrl.sim.registry import SIMULATED, is_simulated, simulated_backend
from grasp_ctrl.sim.world_api import World


def test_every_simulated_backend_builds_a_world_that_satisfies_the_protocol(hand, objects):
    for name in SIMULATED:
        if name == "mujoco":
            pytest.importorskip("mujoco")
        entry = simulated_backend(name)
        world = entry.make_world(hand, objects["lego"], 0, None)
        try:
            assert isinstance(world, World), name
            hand_backend, sensors = entry.make_backends(world, hand)
            world.step()
            assert world.t > 0.0 and world.raw.shape == (len(hand.fingers), 44)
            assert hand_backend.read().q.shape == world.q.shape
            del sensors
        finally:
            world.close()


def test_an_unknown_backend_is_one_line():
    assert not is_simulated("dynamixel") and is_simulated("mujoco") and is_simulated("mock")
    with pytest.raises(UsageError, match="not a simulated backend"):
        simulated_backend("gazebo")
