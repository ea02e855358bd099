"""What a run's summary must say beside its figures: the objects the capacity preflight found
short, and that the mock world is a test double whose figures are not results.

The mock world holds the object still sideways, so each pad reaches tau without the thumb
pushing back what the index and middle push; on the same seeds its success rates differ from
MuJoCo's by more than 10 points for the default policy and the voxel network (docs/results.md).
It stays for tests and quick checks of the controller's plumbing; results come from MuJoCo.
"""

from __future__ import annotations

from typing import Any

from grasp_ctrl.rigs.registry import is_test_double
from grasp_ctrl.trials.episode.capacity_check import CapacityVerdict

MOCK_NOTE = (
    "the mock world is a test double (it holds the object still sideways): its success rates "
    "are not results; run on --backend mujoco (the default) for those (docs/results.md)"
)


def flag_summary(summary: dict[str, Any], short: list[CapacityVerdict]) -> dict[str, Any]:
    """The run summary with ``capacity_short`` (objects the preflight found short) and, on the
    mock world, ``test_double``; unchanged when neither applies."""
    out = dict(summary)
    if short:
        out["capacity_short"] = [v.to_json() for v in short]
    if is_test_double(summary.get("backend")):
        out["test_double"] = True
    return out


def rescored_flags(summary: dict[str, Any], previous: dict[str, Any] | None) -> dict[str, Any]:
    """A summary recomputed from the records (``score``) with the flags the run wrote into its
    summary.json: the preflight's ``capacity_short`` and the mock's ``test_double``."""
    out = dict(summary)
    if previous is not None:
        if isinstance(previous.get("capacity_short"), list):
            out["capacity_short"] = previous["capacity_short"]
        if previous.get("test_double") is True and is_test_double(summary.get("backend")):
            out["test_double"] = True
    return out
