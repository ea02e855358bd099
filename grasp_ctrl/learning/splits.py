"""Trial-wise splits (paper III-B): per source, about 80% of the samples for
training and 10% for validation, and a test set of up to 1.5k samples picked
from the remaining trials. Whole trials only: a trial is in exactly one split."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasp_ctrl.learning.dataset import Dataset


@dataclass(frozen=True)
class Split:
    train: np.ndarray  # sample indices
    val: np.ndarray
    test: np.ndarray


def split_by_trials(
    ds: Dataset, seed: int = 0, train_frac: float = 0.8, val_frac: float = 0.1, test_per_source: int = 1500
) -> Split:
    rng = np.random.default_rng(seed)
    train, val, test = [], [], []
    for source in ds.sources():
        idx_source = np.flatnonzero(ds.source == source)
        trials = np.unique(ds.trial_id[idx_source])
        rng.shuffle(trials)
        parts = [idx_source[ds.trial_id[idx_source] == t] for t in trials]
        sizes = np.array([len(p) for p in parts])
        # a trial goes where its middle sample falls in the cumulative 80 / 10 / 10 partition
        mid = (np.cumsum(sizes) - sizes / 2) / sizes.sum()
        where = np.where(mid < train_frac, 0, np.where(mid < train_frac + val_frac, 1, 2))
        if len(parts) >= 3:  # small sources: still one trial for validation and one for test
            if not np.any(where == 2):
                where[-1] = 2
            if not np.any(where == 1):
                where[np.flatnonzero(where == 0)[-1]] = 1
        train += [p for p, w in zip(parts, where) if w == 0]
        val += [p for p, w in zip(parts, where) if w == 1]
        pool = np.concatenate([p for p, w in zip(parts, where) if w == 2] or [np.empty(0, int)])
        if len(pool) > test_per_source:
            pool = rng.choice(pool, size=test_per_source, replace=False)
        test.append(pool)
    cat = lambda parts: np.sort(np.concatenate(parts)).astype(int) if parts else np.empty(0, int)  # noqa: E731
    return Split(cat(train), cat(val), cat(test))
