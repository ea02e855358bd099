"""Every backend by name (rigs/registry.py) and the World protocol (sim/world_api.py)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from grasp_ctrl.errors import UsageError
from grasp_ctrl.rigs.registry import (
    BACKEND_FLAGS,
    BACKEND_NAMES,
    DEFAULT_BACKEND,
    SIMULATED,
    backend,
    from_flags,
    is_test_double,
    simulated_backend,
)
from grasp_ctrl.sim.world_api import World

PACKAGE = Path(__file__).resolve().parents[2] / "grasp_ctrl"


def test_every_simulated_backend_builds_a_world_that_satisfies_the_protocol(hand, objects):
    for name in SIMULATED:
        entry = simulated_backend(name)
        if entry.world == "mujoco":
            pytest.importorskip("mujoco")
        world = entry.make_world()(hand, objects["lego"], 0, None)
        try:
            assert isinstance(world, World), name
            hand_backend, sensors = entry.make_backends()(world, hand)
            world.step()
            assert world.t > 0.0 and world.raw.shape == (len(hand.fingers), 44)
            assert hand_backend.read().q.shape == world.q.shape
            del sensors
        finally:
            world.close()


def test_each_entry_says_what_it_is_and_offers():
    kinds = {name: backend(name).kind for name in BACKEND_NAMES}
    assert kinds == {
        "mujoco": "simulated",
        "mock": "test_double",
        "dynamixel": "real",
        "dynamixel-emulated": "emulated",
        "allegro_can": "real",
        "allegro_can-emulated": "emulated",
    }
    assert DEFAULT_BACKEND == BACKEND_NAMES[0] == "mujoco"
    assert BACKEND_FLAGS == ("mujoco", "mock", "dynamixel", "allegro_can")
    assert [n for n in BACKEND_NAMES if backend(n).on_hand] == [
        "dynamixel",
        "dynamixel-emulated",
        "allegro_can",
        "allegro_can-emulated",
    ]
    assert [n for n in BACKEND_NAMES if backend(n).truth] == [
        "mujoco",
        "mock",
        "dynamixel-emulated",
        "allegro_can-emulated",
    ]
    assert [n for n in BACKEND_NAMES if backend(n).video] == ["mujoco"]
    assert [n for n in BACKEND_NAMES if backend(n).parallel] == ["mujoco", "mock"]
    assert is_test_double("mock") and not is_test_double("mujoco") and not is_test_double(None)
    assert from_flags("dynamixel").name == "dynamixel"
    assert from_flags("dynamixel", emulate=True).name == "dynamixel-emulated"


def test_the_real_hand_has_no_world_and_bad_names_are_one_line():
    real = backend("dynamixel")
    assert real.world_params(None) is None
    with pytest.raises(UsageError, match="no simulated world"):
        real.make_world()
    with pytest.raises(UsageError, match="not a simulated backend"):
        simulated_backend("dynamixel")
    with pytest.raises(
        UsageError,
        match=r"unknown \(one of mujoco, mock, dynamixel, dynamixel-emulated, allegro_can, allegro_can-emulated\)",
    ):
        backend("gazebo")
    with pytest.raises(UsageError, match="--emulate: only with --backend dynamixel or allegro_can"):
        from_flags("mujoco", emulate=True)


def _string_constants(path: Path) -> list[tuple[int, str]]:
    """The string literals of a module, but not docstrings or f-string parts."""
    tree = ast.parse(path.read_text())
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    return [
        (node.lineno, node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings
    ]


def test_no_backend_name_is_written_outside_the_registry():
    """Code asks the registry what a backend is instead of comparing its name (the hand file's
    arm kinds, also named mock and dynamixel, are the hand file's own words)."""
    hand_file = ("hand.py", "hand_types.py", "hand_sections.py")  # the hand file's reader and its parts
    allowed = {PACKAGE / "rigs" / "registry.py", PACKAGE / "rigs" / "hardware_rig.py"}
    allowed |= {PACKAGE / "config" / name for name in hand_file}
    found = []
    for path in PACKAGE.rglob("*.py"):
        if path in allowed:
            continue
        for line, value in _string_constants(path):
            if value in BACKEND_NAMES:
                found.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {value!r}")
    assert not found, "\n".join(found)


def test_the_command_line_is_built_without_the_compiled_kernels() -> None:
    """`--help` and argument parsing stay fast: building the parser (every command's options, the
    backend registry's names included) imports neither numba nor MuJoCo; a trial loads them."""
    from conftest import modules_after

    assert modules_after("from grasp_ctrl.cli import build_parser; build_parser()", {"numba", "mujoco"}) == set()
