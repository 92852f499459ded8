"""Which steps of a per-step series an output keeps: scene frames at a rate, a series' envelope
(each bin's lowest and highest sample), a path's samples at a stride. Plain numpy: the
recordings (:mod:`pih.records.recordings`), the validation's trace files
(:func:`pih.validation.experiment.stored_samples`) and the planning runs' best paths use it."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def samples_per_bin(time_s: NDArray[np.float64], rate_hz: float) -> int:
    """How many steps make 1/``rate_hz`` s of a trace (at least one)."""
    step = float(np.median(np.diff(time_s))) if len(time_s) > 1 else 0.0
    return max(1, round(1.0 / (rate_hz * step))) if step > 0 else 1


def frame_indices(
    time_s: NDArray[np.float64], rate_hz: float, tail_s: float = 0.0
) -> NDArray[np.intp]:
    """The samples drawn as scene frames: about ``rate_hz`` a second, every one in the last
    ``tail_s`` seconds, and always the first and the last."""
    n = len(time_s)
    if n == 0:
        return np.arange(0)
    tail = np.flatnonzero(time_s >= time_s[-1] - tail_s) if tail_s > 0 else []
    every = samples_per_bin(time_s, rate_hz)
    return np.unique(np.concatenate([np.arange(0, n, every), tail, [n - 1]])).astype(np.intp)


def envelope_indices(
    time_s: NDArray[np.float64], values: NDArray[np.float64], rate_hz: float, tail_s: float
) -> NDArray[np.intp]:
    """The samples of a series kept: in each bin of 1/``rate_hz`` s its first, lowest and
    highest (a peak of one sample survives, and a plot's envelope is the full series'), every one
    in the last ``tail_s`` seconds, and the last."""
    every = samples_per_bin(time_s, rate_hz)
    n = len(values)
    padded = np.full(-(-n // every) * every, np.nan)  # the last bin may be partial
    padded[:n] = values
    bins = padded.reshape(-1, every)
    starts = np.arange(0, len(padded), every)
    # NaN (a diverged step) does not hide a bin's extremes; an all-NaN bin keeps its first sample.
    finite = np.isfinite(bins)
    low = np.where(finite, bins, np.inf).argmin(axis=1)
    high = np.where(finite, bins, -np.inf).argmax(axis=1)
    kept = np.concatenate([starts + low, starts + high, frame_indices(time_s, rate_hz, tail_s)])
    return np.unique(kept[kept < n])


def path_samples(paths: NDArray[np.int64], every: int) -> NDArray[np.bool_]:
    """Which rows of consecutive per-step paths (``paths``: each row's path label, one label a
    run of rows) are kept: each path's rows 0, ``every``, 2 ``every``, … and its last."""
    labels = np.asarray(paths)
    n = labels.size
    if n == 0:
        return np.zeros(0, dtype=bool)
    starts = np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])
    lengths = np.diff(np.r_[starts, n])
    position = np.arange(n) - np.repeat(starts, lengths)
    last = np.zeros(n, dtype=bool)
    last[np.r_[starts[1:], n] - 1] = True
    return (position % max(1, every) == 0) | last
