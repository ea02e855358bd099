"""Named trial protocols for ``run --preset NAME``.

Flags given next to a preset override it (``--preset paper --trials 2``).
"""

from __future__ import annotations

from dataclasses import dataclass

from grasp_ctrl.errors import UsageError

# The two force models the paper compares in Fig. 6. Until the learned policies
# ship, the mock-fitted linear and analytic models stand in for them; change
# this tuple (names in policies/) to switch the preset.
PAPER_POLICIES: tuple[str, ...] = ("linear_mock", "analytic_mock")

PAPER_OBJECTS: tuple[str, ...] = ("chips_can", "cleanser", "lego", "plastic_bottle", "paper_cup", "mustard_bottle")


@dataclass(frozen=True)
class Preset:
    name: str
    description: str
    objects: tuple[str, ...]
    trials: int
    policies: tuple[str, ...]


PRESETS: dict[str, Preset] = {
    "paper": Preset(
        "paper",
        "the paper's lift-and-place protocol (Fig. 6): 6 objects x 5 trials x the two force models",
        PAPER_OBJECTS, 5, PAPER_POLICIES,
    ),
}


def get_preset(name: str) -> Preset:
    try:
        return PRESETS[name]
    except KeyError:
        raise UsageError(f"--preset: unknown preset {name!r} (known: {', '.join(PRESETS)})") from None
