"""suspopt's quarter car against the closed-form variances of the textbook quarter car.

``vehicle.model = "quarter_car"`` (the assembly's own equations, read off as a linear
system) on ISO 8608 roads (a white road velocity), its stationary variances by the
Lyapunov equation, against the closed forms of sprung acceleration, suspension travel
and dynamic tyre load (Gobbi & Mastinu, J. Sound Vib. 245(3), 2001; derived in
docs/spectral.md). The closed forms are the test suite's
(``tests/spectral/test_spectral_closed_form.py``), which share no code with suspopt.

    python benchmarks/quarter_car_closed_form.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from _common import write_result

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests' / 'spectral'))
from test_spectral_closed_form import closed_forms  # noqa: E402

from suspopt.spec.load import config_from_dict  # noqa: E402
from suspopt.spectral import StationaryModel  # noqa: E402
from suspopt.spectral.vehicle import random_road, vehicle_system  # noqa: E402
from suspopt.transcription.vehicle import vehicle_assembly  # noqa: E402

#: (sprung mass, unsprung mass, tyre rate, spring rate, damper rate), ISO class, speed
CASES = (
    ((325.0, 65.0, 232500.0, 20000.0, 1500.0), 'C', 20.0),
    ((300.0, 40.0, 200000.0, 12000.0, 600.0), 'A', 8.0),
    ((450.0, 55.0, 300000.0, 45000.0, 4000.0), 'E', 33.0),
)
METRICS = (
    ('heave', 'sprung acceleration [m/s²]'),
    ('travel_1', 'suspension travel [m]'),
    ('tyre_load_1', 'dynamic tyre load [N]'),
)


def main() -> None:
    rows, data, worst = [], [], 0.0
    for (ms, mu, kt, k, c), road_class, speed in CASES:
        cfg = config_from_dict(
            {
                'vehicle': {
                    'model': 'quarter_car',
                    'chassis_mass': ms,
                    'front': {'wheel_mass': mu, 'tyre_stiffness': kt},
                },
                'maneuver': {'speed': speed},
                'road': {'profile': 'iso8608', 'road_class': road_class},
            }
        )
        system = vehicle_system(vehicle_assembly(cfg, cfg.scenarios()[0], 'low'))
        road = random_road(cfg.road, speed, cfg.layout())
        var = StationaryModel(system, road).variances(system.design_vector({'k_S1': k, 'c_S1': c}))
        got = dict(zip(system.outputs, var))
        want = closed_forms(k, c, road.velocity_intensity(), ms=ms, mu=mu, kt=kt)
        car = f'm_s {ms:g}, m_u {mu:g}, k_T {kt:g}, k {k:g}, c {c:g}'
        case = f'{car}; class {road_class}, {speed:g} m/s'
        for (term, label), w in zip(METRICS, want):
            rel = abs(got[term] - w) / w
            worst = max(worst, rel)
            rows.append(f'| {case} | {label} | {w**0.5:.6g} | {got[term] ** 0.5:.6g} | {rel:.1e} |')
            data.append({'case': case, 'metric': term, 'closed_form': w, 'suspopt': got[term]})
    markdown = '\n'.join(
        [
            'RMS of the quarter car on a white road velocity (ISO 8608 road, stationary): the '
            'closed forms against suspopt\'s `vehicle.model = "quarter_car"` by the Lyapunov '
            'equation; the relative difference is of the variances.',
            '',
            '| car and road | metric | closed form | suspopt | relative difference |',
            '|---|---|---|---|---|',
            *rows,
            '',
            f'Largest relative difference: {worst:.1e}.',
        ]
    )
    print(markdown)
    print(
        write_result(
            'quarter_car_closed_form', 'The quarter car against its closed forms', markdown, data
        )
    )


if __name__ == '__main__':
    main()
