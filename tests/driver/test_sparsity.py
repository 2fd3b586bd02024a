"""The exact total sparsity from declared structure (suspopt.driver.sparsity) against
OpenMDAO's own dense, randomized total-Jacobian sparsity (the public fallback path), on
small grids of every model; and the coloring is a valid one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from suspopt.driver import structure
from suspopt.driver.sparsity import _dense_sparsity, color_columns, structural_sparsity
from suspopt.spec.load import config_from_dict, full_car_defaults
from suspopt.transcription.problem import VehicleProblem


def _problem(cfg, fidelity):
    scales = tuple(dict.fromkeys(cfg.terms(), 1.0) for _ in cfg.scenarios())
    return VehicleProblem(cfg, fidelity, scales, use_cache=False)


def _cases(cfg):
    small = cfg.replace(transcription=dataclasses.replace(cfg.transcription, segments=5))
    full = full_car_defaults()
    full = config_from_dict(
        {
            **full.to_dict(),
            'objective': {'normalization': 'custom', 'scales': dict.fromkeys(full.terms(), 1.0)},
        }
    )
    # a structure test: 4 segments (too coarse for results, refused in a study file)
    full = full.replace(transcription=dataclasses.replace(full.transcription, segments=4))
    chassis = dataclasses.replace(small.multibody, mount='chassis')
    full_chassis = full.replace(multibody=dataclasses.replace(full.multibody, mount='chassis'))
    return {
        'half car, low': (small, 'low'),
        'half car, mixed': (small, 'mixed'),
        'full car with bars, low': (full, 'low'),
        'half car, mixed, chassis mount': (small.replace(multibody=chassis), 'mixed'),
        'full car with bars, mixed, chassis mount': (full_chassis, 'mixed'),
    }


@pytest.mark.parametrize(
    'case',
    [
        'half car, low',
        'half car, mixed',
        'full car with bars, low',
        'half car, mixed, chassis mount',
        'full car with bars, mixed, chassis mount',
    ],
)
def test_structural_sparsity_equals_openmdaos_dense_sparsity(cfg, case):
    config, fidelity = _cases(cfg)[case]
    with _problem(config, fidelity) as vp:
        vp.problem.run_model()
        lay = vp.driver.layout()
        S = structural_sparsity(vp.problem, lay.constraints, lay.design_vars)
        D = _dense_sparsity(vp.problem, lay.constraints, lay.design_vars)
    assert S.shape == D.shape == (lay.m, lay.n)
    A, B = S.toarray().astype(bool), D.toarray().astype(bool)
    assert np.array_equal(A, B), (
        f'{int((B & ~A).sum())} nonzeros missing, {int((A & ~B).sum())} extra'
    )
    assert structure.supported()


def test_coloring_is_valid_and_compact():
    """No two columns of one color share a row; empty columns get no color; a banded
    pattern needs about its bandwidth in colors."""
    import scipy.sparse as sp

    rng = np.random.default_rng(0)
    n, band = 400, 6
    rows, cols = [], []
    for j in range(n):
        for i in range(max(0, j - band), min(n, j + band)):
            if rng.random() < 0.7:
                rows.append(i)
                cols.append(j)
    rows += list(range(n))  # a dense column (a design parameter) and an empty one
    cols += [n] * n
    J = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n + 2))
    colors = color_columns(J)
    assert colors[n + 1] == -1 and colors[n] >= 0
    Jc = J.tocsc()
    for c in range(colors.max() + 1):
        members = np.nonzero(colors == c)[0]
        hit = np.concatenate([Jc.indices[Jc.indptr[j] : Jc.indptr[j + 1]] for j in members])
        assert np.unique(hit).size == hit.size, f'color {c} columns share a row'
    assert colors.max() + 1 <= 2 * band + 2


def test_dense_rows_are_the_ones_that_would_force_many_colors():
    """Rows go to reverse solves when that saves colors, whatever share of the columns
    they span: four worst-case rows of unequal length (the shortest a fifth of the NLP's
    columns or less) all go; a thousand rows of 300 stay forward (300 colors < 1000
    reverse seeds); no row of DENSE_ROW_MIN or fewer nonzeros goes."""
    from suspopt.driver.sparsity import DENSE_ROW_MIN, dense_rows

    rows = np.full(19120, 20)
    epigraph = np.array([3645, 4005, 7285, 4205])
    assert dense_rows(np.concatenate([rows, epigraph])).tolist() == list(range(19120, 19124))
    assert dense_rows(np.full(1000, 300)).size == 0
    assert dense_rows(np.concatenate([np.full(1000, 300), [5000]])).tolist() == [1000]
    assert dense_rows(np.array([DENSE_ROW_MIN] * 3 + [10])).size == 0
    assert dense_rows(np.zeros(0, dtype=int)).size == 0
