"""Every backend a trial runs on, by name (``run --backend NAME``, run.json's ``backend``).

- ``mujoco``: MuJoCo, the reference world; every reported result comes from it.
- ``mock``: the hand-written test world, a test double (fast; its success rates are not
  results, decision record 0001).
- ``dynamixel``: the real hand (Dynamixel servos, serial fingertip sensors, the hand file's arm).
- ``dynamixel-emulated``: the real hand's backends over pseudo-terminals (an emulated servo chain
  and sensor bridges) on a MuJoCo world: ``run --backend dynamixel --emulate``.
- ``allegro_can``: a real torque-controlled hand on CAN (the Allegro v4; python-can, the ``can``
  extra), serial fingertip sensors, the hand file's arm.
- ``allegro_can-emulated``: its backends on python-can's virtual bus (the Allegro emulator) and
  the sensor bridges on a MuJoCo world: ``run --backend allegro_can --emulate``.

Each entry says what it is and what it offers, and builds a trial's world and hand and sensor
backends; the rest of the package asks it instead of comparing backend names. MuJoCo, the
servo SDK and the emulators are imported only when an entry builds with them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from grasp_ctrl.config.hand import HandConfig
from grasp_ctrl.config.objects import ObjectProfile
from grasp_ctrl.errors import UsageError
from grasp_ctrl.sim.variation import Variation

if TYPE_CHECKING:  # the world's interface pulls in the compiled kernels: not for --help
    from grasp_ctrl.sim.world_api import World

WorldFactory = Callable[[HandConfig, ObjectProfile, int, Any], "World"]
BackendFactory = Callable[[Any, HandConfig], tuple[Any, Any]]
ArmFactory = Callable[[Any, HandConfig], Any]
Kind = Literal["simulated", "test_double", "real", "emulated"]

#: The reference world: the default backend of every command and library call.
REFERENCE_WORLD = "mujoco"
DEFAULT_BACKEND = REFERENCE_WORLD
#: The hand-written test world (a test double: fast; its success rates are not results).
TEST_WORLD = "mock"
#: The real hand's backends on emulated links (``run --backend dynamixel --emulate``).
EMULATED_HAND = "dynamixel-emulated"
#: The Allegro on CAN, and its backends on the virtual bus (``run --backend allegro_can --emulate``).
ALLEGRO_CAN = "allegro_can"
EMULATED_ALLEGRO_CAN = "allegro_can-emulated"


@dataclass(frozen=True)
class Backend:
    name: str  # as run.json records it
    flag: str  # ``--backend``'s value (the emulated hand: ``dynamixel`` with ``--emulate``)
    kind: Kind
    description: str
    world: str | None  # the simulated world its trials run in; None: the real bench
    video: bool = False  # ``run --record-video``
    parallel: bool = False  # trials in worker processes or as Ray tasks (``--jobs``, ``--executor ray``)
    _world: Callable[[], WorldFactory] | None = None
    _backends: Callable[[bool], BackendFactory] | None = None  # realtime -> (world, hand) -> (hand, sensors)
    _params: Callable[[Variation], Any] | None = None
    _arm: Callable[[], ArmFactory] | None = None  # a simulated world's arm (its wrist target)
    actuator: str | None = None  # the hand file's ``actuator`` the entry's hand backends drive (on a hand)
    extra: str | None = None  # the optional extra its backends need (pyproject.toml), if any

    def check_hand(self, hand: HandConfig) -> None:
        """A one-line error where the hand file's joints are not what this entry drives, or the
        extra its backends need is not installed."""
        if self.actuator is None or hand.actuator == self.actuator:
            if self.extra == "can":
                from grasp_ctrl.hardware.allegro.bus import require_python_can

                require_python_can()
            return
        what = f"--backend {self.flag}" + (" --emulate" if self.kind == "emulated" else "")
        others = [b.flag for b in _ENTRIES.values() if b.actuator == hand.actuator and b.kind == self.kind]
        fix = f"--backend {others[0]}" if others else "simulate it: run --backend mujoco or mock"
        raise UsageError(
            f"{what} drives actuator = {self.actuator!r} hands; hand {hand.name!r} ({hand.path}) has "
            f"actuator = {hand.actuator!r} ({fix})"
        )

    @property
    def on_hand(self) -> bool:
        """Trials go through the real hand's backends (the hand itself, or its emulation)."""
        return self.kind in ("real", "emulated")

    @property
    def truth(self) -> bool:
        """A world whose truth judges the trials and feeds the oracle (every backend but the real hand)."""
        return self.world is not None

    def make_world(self) -> WorldFactory:
        """(hand, object, seed, params or None) -> the trial's World."""
        if self._world is None:
            raise UsageError(f"backend {self.name!r}: the real hand has no simulated world")
        return self._world()

    def make_backends(self, realtime: bool = False) -> BackendFactory:
        """(world, hand) -> (hand backend, sensor backend) of one trial; ``realtime``: on the
        wall clock (the emulated hand's dry run)."""
        if self._backends is None:
            raise UsageError(f"backend {self.name!r}: trials on the real hand open its rig (rigs/hardware_rig.py)")
        return self._backends(realtime)

    def make_arm(self) -> ArmFactory:
        """(world, hand) -> the arm backend of one trial on a simulated world (it moves the wrist target)."""
        if self._arm is None:
            raise UsageError(
                f"backend {self.name!r}: the real hand's arm comes from its hand file (rigs/hardware_rig.py)"
            )
        return self._arm()

    def world_params(self, variation: Variation | None) -> Any:
        """The parameters of a trial's world under ``variation``; None (the world's own defaults)
        without a variation or a world."""
        if variation is None or self._params is None:
            return None
        return self._params(variation)


def _mock_world() -> WorldFactory:
    from grasp_ctrl.sim.mock.world import MockWorld

    return MockWorld


def _mock_backends(realtime: bool) -> BackendFactory:
    from grasp_ctrl.sim.mock.backends import mock_backends

    return mock_backends


def _mock_arm() -> ArmFactory:
    from grasp_ctrl.sim.mock.backends import MockArm

    return MockArm


def _mock_params(v: Variation) -> Any:
    from grasp_ctrl.sim.world_params import WorldParams

    return WorldParams(variation=v)


def _mujoco_world() -> WorldFactory:
    from grasp_ctrl.sim.mujoco.backends import make_world

    return make_world


def _mujoco_backends(realtime: bool) -> BackendFactory:
    from grasp_ctrl.sim.mujoco.backends import mujoco_backends

    return mujoco_backends


def _world_arm() -> ArmFactory:
    from grasp_ctrl.sim.world_backends import WorldArm

    return WorldArm


def _mujoco_params(v: Variation) -> Any:
    from grasp_ctrl.sim.mujoco.world import MuJoCoParams

    return MuJoCoParams(variation=v)


def _emulated_backends(realtime: bool) -> BackendFactory:
    from grasp_ctrl.emulators.world_rig import emulated_backends, realtime_backends

    return realtime_backends if realtime else emulated_backends


def _allegro_emulated_backends(realtime: bool) -> BackendFactory:
    from grasp_ctrl.emulators.allegro_can_world import allegro_emulated_backends, allegro_realtime_backends

    return allegro_realtime_backends if realtime else allegro_emulated_backends


_ENTRIES: dict[str, Backend] = {
    b.name: b
    for b in (
        Backend(
            "mujoco",
            "mujoco",
            "simulated",
            "MuJoCo: the reference world",
            "mujoco",
            video=True,
            parallel=True,
            _world=_mujoco_world,
            _backends=_mujoco_backends,
            _params=_mujoco_params,
            _arm=_world_arm,
        ),
        Backend(
            TEST_WORLD,
            TEST_WORLD,
            "test_double",
            "the hand-written test world (fast; holds the object still sideways)",
            "mock",
            parallel=True,
            _world=_mock_world,
            _backends=_mock_backends,
            _params=_mock_params,
            _arm=_mock_arm,
        ),
        Backend(
            "dynamixel",
            "dynamixel",
            "real",
            "the real hand: Dynamixel servos, serial fingertip sensors",
            None,
            actuator="dynamixel",
        ),
        Backend(
            EMULATED_HAND,
            "dynamixel",
            "emulated",
            "the real hand's backends on emulated links (pseudo-terminals) over a MuJoCo world",
            "mujoco",
            _world=_mujoco_world,
            _backends=_emulated_backends,
            _params=_mujoco_params,
            _arm=_world_arm,
            actuator="dynamixel",
        ),
        Backend(
            ALLEGRO_CAN,
            ALLEGRO_CAN,
            "real",
            "the real Allegro hand on CAN (python-can; the host runs the joint PD loop), serial fingertip sensors",
            None,
            actuator="torque_pd",
            extra="can",
        ),
        Backend(
            EMULATED_ALLEGRO_CAN,
            ALLEGRO_CAN,
            "emulated",
            "the Allegro's CAN backend on python-can's virtual bus (an emulated hand) over a MuJoCo world",
            "mujoco",
            _world=_mujoco_world,
            _backends=_allegro_emulated_backends,
            _params=_mujoco_params,
            _arm=_world_arm,
            actuator="torque_pd",
            extra="can",
        ),
    )
}

#: Every backend's name, the reference world first.
BACKEND_NAMES: tuple[str, ...] = tuple(_ENTRIES)
#: ``--backend``'s choices.
BACKEND_FLAGS: tuple[str, ...] = tuple(dict.fromkeys(b.flag for b in _ENTRIES.values()))
#: The simulated worlds (``--backend mujoco``, ``--backend mock``).
SIMULATED: tuple[str, ...] = tuple(b.name for b in _ENTRIES.values() if b.kind in ("simulated", "test_double"))


def backend(name: str) -> Backend:
    """The entry for ``name``, or a one-line error naming the backends."""
    try:
        return _ENTRIES[name]
    except KeyError:
        raise UsageError(f"--backend {name!r}: unknown (one of {', '.join(BACKEND_NAMES)})") from None


def simulated_backend(name: str) -> Backend:
    """The entry of a simulated world, or a one-line error naming them."""
    entry = _ENTRIES.get(name)
    if entry is None or entry.on_hand:
        raise UsageError(f"--backend {name!r}: not a simulated backend (one of {', '.join(SIMULATED)})")
    return entry


def from_flags(flag: str, emulate: bool = False) -> Backend:
    """The backend that ``--backend FLAG`` (with ``--emulate``) names."""
    for entry in _ENTRIES.values():
        if entry.flag == flag and (entry.kind == "emulated") == emulate:
            return entry
    if emulate:
        hands = " or ".join(b.flag for b in _ENTRIES.values() if b.kind == "emulated")
        raise UsageError(f"--emulate: only with --backend {hands} (it emulates the real hand's links)")
    raise UsageError(f"--backend {flag!r}: unknown (one of {', '.join(BACKEND_FLAGS)})")


def is_test_double(name: object) -> bool:
    entry = _ENTRIES.get(name) if isinstance(name, str) else None
    return entry is not None and entry.kind == "test_double"
