"""Stationary statistics of a time-marching run on suspopt's ISO 8608 road, for the
comparisons with the spectral method (tests/studies, benchmarks/spectral_time_domain.py).

The mean square of every metric over ``[t0, T]`` (the samples' mean: unbiased for a
stationary response whatever the sampling step) and its standard error by batch means:
the window cut into ``batches`` consecutive batches, much longer than the response's
correlation time, whose mean squares are taken as independent."""

from __future__ import annotations

import numpy as np

from suspopt.records.trajectory import Trajectory

#: the trajectory's signal of each metric kind
SIGNALS = {
    'heave': 'zdd_C',
    'pitch': 'thdd_C',
    'roll': 'phidd_C',
    'tyre_load': 'F_T',
    'travel': 'travel',
    'comfort': 'a_w',
}


def term_samples(tr: Trajectory, term: str, labels: tuple[str, ...], seats: tuple[str, ...]):
    """The samples of one objective term's signal."""
    if term in ('heave', 'pitch', 'roll'):
        return np.asarray(tr.values[SIGNALS[term]])
    kind, _, which = term.rpartition('_')
    values = np.asarray(tr.values[SIGNALS[kind]])
    column = seats.index(which) if kind == 'comfort' else labels.index(which)
    return values.reshape(values.shape[0], -1)[:, column]


def mean_squares(
    tr: Trajectory,
    terms: tuple[str, ...],
    labels: tuple[str, ...],
    seats: tuple[str, ...],
    t0: float,
    batches: int = 10,
) -> tuple[dict[str, float], dict[str, float]]:
    """Each term's mean square over ``t >= t0`` and its standard error by batch means."""
    keep = tr.t >= t0
    ms, se = {}, {}
    for term in terms:
        y = term_samples(tr, term, labels, seats)[keep]
        b = np.array([np.mean(c**2) for c in np.array_split(y, batches)])
        ms[term] = float(np.mean(y**2))
        se[term] = float(np.std(b, ddof=1) / np.sqrt(batches))
    return ms, se
