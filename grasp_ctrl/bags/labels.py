"""Force labels for tactile frames from a wrench topic (``import-bag --wrench``).

The force at a frame's time is interpolated linearly between the two wrench messages around
it; frames before the first or after the last wrench message get no label and are left out.
Its direction labels the frame where the force reaches ``min_force_n``; a frame below it
takes the direction of the nearest frame (in time) that reaches it, because the readers of
direction labels want a unit vector on every row (they pick frames in contact by pdc).
"""

from __future__ import annotations

import numpy as np

from grasp_ctrl.errors import UsageError


def force_at(t_ns: np.ndarray, t_wrench_ns: np.ndarray, f_wrench: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forces (n, 3) N, mask of the frames inside the wrench topic's time span)."""
    order = np.argsort(t_wrench_ns, kind="stable")
    tw, fw = t_wrench_ns[order], f_wrench[order]
    t0 = int(tw[0])  # times relative to the first wrench: epoch ns are beyond a float's integers
    x, xp = (t_ns - t0).astype(float), (tw - t0).astype(float)
    inside = (t_ns >= tw[0]) & (t_ns <= tw[-1])
    f = np.stack([np.interp(x, xp, fw[:, a]) for a in range(3)], axis=1)
    return f, inside


def directions(t_ns: np.ndarray, f: np.ndarray, min_force_n: float) -> np.ndarray | None:
    """Unit directions (n, 3) of the forces, the nearest strong one's below ``min_force_n``; None
    when no force reaches it."""
    order = np.argsort(t_ns, kind="stable")  # stamps need not arrive in order
    ts, fs = t_ns[order], f[order]
    norm = np.linalg.norm(fs, axis=1)
    strong = np.flatnonzero(norm >= min_force_n)
    if not len(strong):
        return None
    unit = fs[strong] / norm[strong, None]
    t_strong = ts[strong]
    after = np.clip(np.searchsorted(t_strong, ts), 0, len(strong) - 1)
    before = np.clip(after - 1, 0, len(strong) - 1)
    pick = np.where(np.abs(ts - t_strong[before]) <= np.abs(t_strong[after] - ts), before, after)
    sorted_out = unit[pick]
    sorted_out[strong] = unit  # a strong frame is its own label, even beside another at the same time
    out = np.empty_like(sorted_out)
    out[order] = sorted_out
    return out


def check_wrenches(n: int, where: str) -> None:
    if n < 2:
        raise UsageError(f"{where}: {n} wrench message(s); at least 2 are needed to label frames between them")
