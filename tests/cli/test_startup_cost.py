"""What a command costs before its work starts: one command's parser loads no other command's
module, and the solves made before a trial are kept on disk (numeric/solve_cache.py) with
results bit-identical to solving again."""

from __future__ import annotations

import argparse
import dataclasses
import pickle

import numpy as np
import pytest
from conftest import modules_after

from grasp_ctrl.cli import _command_modules, build_parser
from grasp_ctrl.controller.grip_targets import closure_targets, grip_targets
from grasp_ctrl.numeric import solve_cache
from grasp_ctrl.numeric.solve_cache import key_of, stored


def test_each_command_module_is_named_after_its_command():
    for mod in _command_modules():
        assert mod.__name__.rsplit(".", 1)[1] == f"cmd_{mod.NAME.replace('-', '_')}"


def test_one_commands_parser_parses_as_the_whole_parser():
    argv = ["run", "--objects", "lego,chips_can", "--trials", "2", "--seed", "4"]
    whole, one = vars(build_parser().parse_args(argv)), vars(build_parser("run").parse_args(argv))
    assert {k: v for k, v in whole.items() if k != "_run"} == {k: v for k, v in one.items() if k != "_run"}
    subparsers = next(a for a in build_parser("run")._actions if isinstance(a, argparse._SubParsersAction))
    assert list(subparsers.choices) == ["run"]
    assert (
        len(next(a for a in build_parser("no-such")._actions if isinstance(a, argparse._SubParsersAction)).choices) > 20
    )


def test_the_run_commands_parser_loads_no_other_command():
    loaded = modules_after(
        "from grasp_ctrl.cli import build_parser; build_parser('run')",
        {"grasp_ctrl.cli.cmd_train", "grasp_ctrl.cli.cmd_tune", "grasp_ctrl.cli.cmd_run"},
    )
    assert loaded == {"grasp_ctrl.cli.cmd_run"}


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv(solve_cache.ENV, str(tmp_path / "solves"))
    return tmp_path / "solves"


def test_a_stored_result_is_the_solved_one_to_the_bit(cache_dir):
    horizontal = np.array([[1.0, 0.3, -0.9], [0.1, -0.2, 0.05]])
    first = closure_targets(horizontal, 2.0)  # solved and stored
    assert len(list(cache_dir.rglob("*.pickle"))) == 1
    again = closure_targets(horizontal, 2.0)  # read back
    assert again.tobytes() == first.tobytes() == closure_targets.uncached(horizontal, 2.0).tobytes()
    vectors = np.array([[1.0, 0.1, 0.0], [0.3, -0.2, 0.0], [-0.9, 0.05, 0.0]])
    mask = np.array([True, True, True])
    cached = grip_targets(vectors, mask, 2.0, "force_closure")
    assert cached.min() == 2.0 and cached.max() > 2.0  # the thumb-like third pushes back the other two
    assert grip_targets(vectors, mask, 2.0, "force_closure").tobytes() == cached.tobytes()


def test_the_key_spells_every_bit_and_type():
    assert key_of("f", {"x": 1.0}) != key_of("f", {"x": np.nextafter(1.0, 2.0)})
    assert key_of("f", {"x": 1.0}) != key_of("f", {"x": 1})
    assert key_of("f", {"x": np.zeros(3)}) != key_of("f", {"x": np.zeros(3, dtype=np.float32)})
    assert key_of("f", {"x": np.zeros((3, 1))}) != key_of("f", {"x": np.zeros((1, 3))})
    assert key_of("f", {"x": (1.0, "a")}) != key_of("f", {"x": [1.0, "a"]})
    assert key_of("f", {"x": 1.0}) != key_of("g", {"x": 1.0})

    @dataclasses.dataclass(frozen=True)
    class A:
        a: float
        b: tuple[str, ...]

    assert key_of("f", {"x": A(1.0, ("p",))}) == key_of("f", {"x": A(1.0, ("p",))})
    assert key_of("f", {"x": A(1.0, ("p",))}) != key_of("f", {"x": A(1.0, ("q",))})
    assert key_of("f", {"x": object()}) is None  # not spelled: solved every time


def test_damaged_entries_unwritable_folders_and_off_only_mean_solving_again(cache_dir, monkeypatch):
    calls = []

    @stored(ignore=("helper",))
    def solve(x: float, helper: object = None) -> float:
        calls.append(x)
        return x * 2.0

    assert solve(1.5, helper=object()) == 3.0 and solve(1.5, helper=object()) == 3.0
    assert calls == [1.5]  # the ignored argument is not in the key
    (entry,) = cache_dir.rglob("*.pickle")
    entry.write_bytes(b"not a pickle")
    assert solve(1.5) == 3.0 and calls == [1.5, 1.5]
    assert pickle.loads(entry.read_bytes()) == 3.0  # stored anew
    monkeypatch.setenv(solve_cache.ENV, "off")
    assert solve(1.5) == 3.0 and calls == [1.5, 1.5, 1.5]
    blocker = cache_dir.parent / "a_file"
    blocker.write_text("")
    monkeypatch.setenv(solve_cache.ENV, str(blocker))  # a folder that cannot be made
    assert solve(2.0) == 4.0 and calls[-1] == 2.0


def test_an_exception_is_raised_each_time_and_never_stored(cache_dir):
    calls = []

    @stored()
    def unreachable(x: float) -> float:
        calls.append(x)
        raise ValueError("cannot reach")

    for _ in range(2):
        with pytest.raises(ValueError, match="cannot reach"):
            unreachable(1.0)
    assert calls == [1.0, 1.0] and not list(cache_dir.rglob("*.pickle"))


def test_a_warm_cache_keeps_scipy_optimize_out_of_a_runs_preparation(cache_dir):
    """The preflight and the controllers' preparation of the default objects: with their solves
    stored once, a fresh interpreter makes them again without importing scipy.optimize."""
    code = (
        "from grasp_ctrl.config.hand import load_hand; from grasp_ctrl.config.objects import load_objects;"
        "from grasp_ctrl.files.paths import hand_configs_dir;"
        "from grasp_ctrl.trials.episode.capacity_check import check_objects;"
        "from grasp_ctrl.controller.registry import make_controller; import numpy as np;"
        "hand = load_hand(hand_configs_dir() / 'leap_hand.toml');"
        "objs = list(load_objects(hand_configs_dir() / 'objects.toml', hand=hand.name).values());"
        "check_objects(hand, objs); [make_controller(hand, o, np.zeros(3)) for o in objs]"
    )
    # the probe's interpreter inherits the fixture's cache folder
    assert modules_after(code, {"scipy.optimize"}) == {"scipy.optimize"}  # cold: solved
    assert modules_after(code, {"scipy.optimize"}) == set()  # warm: read back
