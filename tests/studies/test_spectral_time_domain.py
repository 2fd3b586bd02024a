"""The spectral method against suspopt's own time marching on its own ISO 8608 generator
(suspopt.verification.timemarching.simulate, road.profile = "iso8608").

The generator puts the road's power between ``n_min`` and ``n_max`` only (a sum of
cosines), while the spectral model's road velocity is white: the time-domain mean
squares are compared with the spectral integral over that band (``spectral_variances(...,
band=)``, exact wheelbase delay and coherence). A narrow band (``n_max = 0.3`` cycle/m, 6
Hz at 20 m/s, below the wheel hop) makes the band's effect large, so the test also shows
that the white-velocity value is rejected. The scatter of a finite run is measured by
batch means (:mod:`stationary_sampling`). ``benchmarks/spectral_time_domain.py`` runs the
default band on the quarter, half and full car, 200 s and several seeds."""

from __future__ import annotations

import numpy as np
import pytest
from stationary_sampling import mean_squares

from suspopt.spec.load import config_from_dict
from suspopt.spectral import StationaryModel
from suspopt.spectral.integral import spectral_variances
from suspopt.spectral.vehicle import road_band
from suspopt.studies.spectral import spectral_cases
from suspopt.verification.timemarching import simulate

#: standard errors (batch means) a time-domain mean square may be from the spectral one
SIGMAS = 3.0


@pytest.mark.slow
def test_time_marching_on_the_iso_road_agrees_with_the_band_limited_spectral_values():
    speed, horizon = 20.0, 25.0
    cfg = config_from_dict(
        {
            'vehicle': {'model': 'quarter_car'},
            'comfort': {'seats': [{'name': 'driver'}]},
            'maneuver': {'speed': speed, 'horizon': horizon},
            'road': {
                'profile': 'iso8608',
                'road_class': 'C',
                'seed': 3,
                'n_max': 0.3,
                'length': speed * horizon,
            },
            'objective': {'weights': {'heave': 1.0}},
            'transcription': {'segments': 'auto'},
        }
    )
    (case,) = spectral_cases(cfg)
    p = case.system.design_vector(cfg.design.initial())
    band = spectral_variances(case.system, case.road, p, band=road_band(cfg.road, speed), rtol=1e-8)
    white = StationaryModel(case.system, case.road).variances(p)
    tr = simulate(cfg, 'low', rtol=1e-3, atol=1e-6, t_eval=np.arange(0.0, horizon + 1e-9, 0.01))
    ms, se = mean_squares(tr, case.system.outputs, ('1',), ('driver',), t0=2.0)
    for term, v_band, v_white in zip(case.system.outputs, band, white):
        assert abs(ms[term] - v_band) <= SIGMAS * se[term], (term, ms[term] / v_band, se[term])
        if term != 'travel_1':  # travel hardly feels the road above 6 Hz
            assert abs(ms[term] - v_white) > SIGMAS * se[term], (term, ms[term] / v_white)
