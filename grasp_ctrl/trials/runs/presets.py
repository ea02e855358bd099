"""Named trial protocols for ``run --preset NAME``.

Flags given next to a preset override it (``--preset paper --trials 2``).
"""

from __future__ import annotations

from dataclasses import dataclass

from grasp_ctrl.errors import UsageError

# The paper's Fig. 6 compares Su et al. (trained on rigid-ft) with the voxel network
# (trained on all three sources); both are trained here on the simulated BioTac.
# The third column is the authors' network fine-tuned on the simulated sensor
# (icra19_finetuned_mock): its real-data weights read another BioTac's magnitude
# wrongly, and fine-tuning is the remedy a user has.
PAPER_POLICIES: tuple[str, ...] = ("su_rigid_ft_mock", "voxel_alpha_mixed_mock", "icra19_finetuned_mock")

PAPER_OBJECTS: tuple[str, ...] = ("chips_can", "cleanser", "lego", "plastic_bottle", "paper_cup", "mustard_bottle")


@dataclass(frozen=True)
class Preset:
    name: str
    description: str
    objects: tuple[str, ...]
    trials: int
    policies: tuple[str, ...]
    controller: str = "paper"
    hand: str | None = None  # a hand file in hand_configs/; None: the default hand
    variation: str | None = None  # the simulated world's variation profile; None: the default


PRESETS: dict[str, Preset] = {
    "paper": Preset(
        "paper",
        "the paper's lift-and-place protocol (Fig. 6) on the paper's hand (hand_configs/allegro_hand.toml) with "
        "the paper's controller (as the hand file reads it: the Allegro pushes each pad to tau, then holds) under "
        "the nominal variation: 6 objects x 5 trials x Su et al., the voxel network and the authors' network "
        "fine-tuned on the simulated sensor",
        PAPER_OBJECTS,
        5,
        PAPER_POLICIES,
        "paper",  # Fig. 6 is the paper's controller's experiment
        "allegro_hand.toml",  # the paper's hand: an Allegro with BioTacs on index, middle and thumb
        "nominal",  # a lab bench where the object is set down on its mark
    ),
}


def get_preset(name: str) -> Preset:
    try:
        return PRESETS[name]
    except KeyError:
        raise UsageError(f"--preset: unknown preset {name!r} (known: {', '.join(PRESETS)})") from None
