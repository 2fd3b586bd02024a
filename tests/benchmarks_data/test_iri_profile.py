"""The shipped road profile ``examples/data/iri_737b.csv`` (the co-design benchmark's road,
``benchmarks/codesign_peer.py``) and its licence notice.

The statistics are those stated where the profile was handed over (standard deviation
5.0 mm, range -12.3 to +16.1 mm, 1 cm spacing over 100 m), to the printed precision."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parents[2] / 'examples' / 'data'
PROFILE = DATA / 'iri_737b.csv'
NOTICE = DATA / 'iri_737b.LICENSE.txt'


@pytest.fixture(scope='module')
def profile() -> np.ndarray:
    return np.loadtxt(PROFILE, delimiter=',', skiprows=1)


def test_profile_layout() -> None:
    lines = PROFILE.read_text().splitlines()
    assert lines[0] == 'distance_m,height_m'
    assert len(lines) == 10_001  # the header and 10 000 samples


def test_profile_spacing(profile: np.ndarray) -> None:
    x = profile[:, 0]
    assert profile.shape == (10_000, 2)
    assert x[0] == 0.0
    assert x[-1] == pytest.approx(99.99, abs=1e-12)
    np.testing.assert_allclose(np.diff(x), 0.01, atol=1e-9)


def test_profile_statistics(profile: np.ndarray) -> None:
    z_mm = 1e3 * profile[:, 1]
    assert round(float(z_mm.std()), 1) == 5.0
    assert round(float(z_mm.min()), 1) == -12.3
    assert round(float(z_mm.max()), 1) == 16.1


def test_licence_notice() -> None:
    text = NOTICE.read_text()
    assert 'Copyright (c) 2017, Daniel Herber' in text
    assert 'BSD 3-Clause License' in text
    assert 'iri_737b.csv' in text and 'dt-qp-project' in text
    # the three conditions and the disclaimer, in full
    for phrase in (
        'Redistributions of source code must retain the above copyright notice',
        'Redistributions in binary form must reproduce the above copyright notice',
        'Neither the name of the copyright holder nor the names of its',
        'EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.',
    ):
        assert phrase in text, phrase
