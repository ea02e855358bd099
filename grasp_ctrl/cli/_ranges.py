"""The allowed range of every numeric flag, applied to the parsers in one place.

``apply_ranges(command, parser)`` replaces each ``type=float`` flag's converter by one
that refuses NaN, infinities and numbers out of float range, and gives the flags
listed in ``RANGES`` their bounds; argparse then prints one line naming the flag and
the range and exits 2. ``run``'s and ``tune``'s ``--trials`` and ``--seed`` are checked by
their commands (``check_trials_and_seed``: a preset may give the count), with their own messages.
"""

from __future__ import annotations

import argparse

from grasp_ctrl.numeric.numbers import float_type, int_type

SEED = (0, 2**63 - 1)
THREADS = (1, 1024)
FRAMES = (1, 1_000_000)
COUNTS = 4095.0  # a BioTac channel's largest count

# command -> flag -> (lo, hi) or (lo, hi, lo_open) for floats
RANGES: dict[str, dict[str, tuple]] = {
    "run": {"--threads": THREADS},
    "plot": {"--fps": (0.0, 100.0, True), "--frames": (1, 10_000)},
    "calibrate": {"--ridge": (0.0, 1e6), "--tare-frames": FRAMES, "--min-pdc": (0.0, COUNTS), "--threads": THREADS},
    "evaluate-direction": {
        "--tare-frames": FRAMES,
        "--threshold": (0.0, COUNTS),
        "--frames": FRAMES,
        "--min-pdc": (0.0, COUNTS),
        "--threads": THREADS,
    },
    "pushing-gt": {
        "--particles": (1, 100_000),
        "--k": (0.0, 1e6, True),
        "--window-s": (0.0, 3600.0, True),
        "--speed-threshold": (0.0, 100.0),
    },
    "sensors": {
        "--baud": (9600, 12_000_000),
        "--seconds": (0.0, 1e6, True),
        "--refresh": (0.0, 3600.0, True),
        "--emulate-corrupt": (0.0, 1.0),
    },
    "train": {
        "--beta": (0.0, 1e6),
        "--epochs": (1, 1_000_000),
        "--batch-size": (1, 10_000_000),
        "--lr": (0.0, 10.0, True),
        "--patience": (1, 1_000_000),
        "--threads": THREADS,
        "--jobs": (1, 1024),
        "--synthetic": (0, 100_000_000),
        "--seed": SEED,
        "--tare-frames": FRAMES,
        "--test-per-source": (0, 100_000_000),
    },
    "synth": {"--seed": SEED},  # --n: synth says it itself
    "hand-check": {"--baud": (9600, 4_500_000), "--step": (0.0, 3.2, True)},
    "lift-capacity": {"--min-margin": (0.0, 1000.0, True)},
    "biotac-anchors": {"--n": (1, 10_000_000), "--seed": SEED},
    "fit-mock-policies": {"--samples": (1, 100_000_000), "--seed": SEED},
    "grasp-contacts": {"--trials": (1, 100_000), "--seed": SEED, "--every": (1, 1_000_000)},
    "convert-icra19": {"--tol": (0.0, 1.0, True), "--seed": SEED},
    "view": {"--seed": SEED},
    "evaluate": {
        "--synthetic": (0, 100_000_000),
        "--seed": SEED,
        "--tare-frames": FRAMES,
        "--test-per-source": (0, 100_000_000),
    },
}


def check_trials_and_seed(trials: int, seed: int | None) -> None:
    """``run``'s and ``tune``'s ``--trials`` (1 to the run file's MAX_TRIALS: each trial's seed is
    planned before the first runs, so a larger count would hang before it is refused) and
    ``--seed`` (None: not given), with their own messages."""
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.trials.runs.manifest import MAX_TRIALS

    if not 1 <= trials <= MAX_TRIALS:
        raise UsageError(f"--trials: from 1 to {MAX_TRIALS} (got {trials})")
    if seed is not None and not SEED[0] <= seed <= SEED[1]:
        raise UsageError(f"--seed: an integer from 0 to 2**63-1 (got {seed})")


def apply_ranges(command: str, parser: argparse.ArgumentParser) -> None:
    limits = RANGES.get(command, {})
    for action in parser._actions:  # argparse has no public way to walk a parser's flags
        flag = next((s for s in action.option_strings if s.startswith("--")), None)
        if flag in limits:
            lo, hi, *rest = limits[flag]
            if action.type is int:
                action.type = int_type(int(lo), int(hi))
            elif action.type is float:
                action.type = float_type(float(lo), float(hi), bool(rest and rest[0]))
        elif action.type is float:
            action.type = float_type()
