"""Published cars, as plain study-file dictionaries.

``BMW_E90``: a BMW E90 (330i, 2006) from Chrono::Vehicle's model of it
(github.com/projectchrono/chrono, ``src/chrono_models/vehicle/bmw/``: ``BMW_E90_Chassis``,
``_Vehicle``, ``_MacPhersonStrut``, ``_DoubleWishbone``, ``_FrontWheel``, ``_RearWheel``,
``_AntiRollBarFront/Rear``, ``_TMsimpleTireFront``, ``_TMeasyTireRear``; data credited there
to SAE 2007-01-0817 and 2007-01-0818):

* sprung mass 1442.1 kg, roll and pitch inertia 572 and 2487 kg m², centre of mass 1.371 m
  behind the front axle, wheelbase 2.75717 m, tracks 2 × 0.750062 and 2 × 0.7493 m;
* unsprung mass per corner: spindle + upright + wheel + tyre + half of the arms (front
  9.96 + 13.51 + 18.0 + 11.2 + (2.72 + 13.5)/2 = 60.8 kg; rear 14.705 + 19.45 + 15.4 + 11.2
  + (5.813 + 23.965)/2 = 75.6 kg; the 225/40 R18 tyre's 11.2 kg for both, Chrono's TMeasy
  rear tyre mass of 37.6 kg being another vehicle's);
* tyre vertical rates 310.5 kN/m (front) and 357.9 kN/m (rear);
* spring 29,770 / 37,130 N/m and damper 4,352 / 5,810 N s/m (front / rear), Chrono's rates
  of the elements themselves, used here as the initial design at the wheel (the
  low-fidelity model's springs act at the wheel);
* anti-roll bars 75,745 N m/rad front (marked "todo" in Chrono) and 4,030 N m/rad rear;
* mixed-fidelity corners (``multibody/data/``): ``bmw_e90_front``, the MacPherson strut
  of ``macpherson.toml`` with these masses, and ``bmw_e90_rear``, Chrono's rear double
  A-arm in the front view with its spring-damper on Chrono's spring line. Each linkage's
  moving mass is the unsprung mass above: its bodies carry the terms of the sum, the
  arms and the strut at half their mass (radii of gyration kept). There, as for the
  paper's double wishbone, k_S and c_S are the spring-damper's own rates, not the wheel's:
  the strut's motion ratio is close to 1, the rear spring's well below it (the wheel
  feeds back only a fraction of the rate, the files' headers give it), so the same
  design makes a softer, less damped rear in the mixed model than in the low-fidelity
  one.
"""

from __future__ import annotations

BMW_E90 = {
    'vehicle': {
        'model': 'full_car',
        'chassis_mass': 1442.1,
        'chassis_pitch_inertia': 2487.0,
        'chassis_roll_inertia': 572.0,
        'front': {
            'axle_position': 1.371,
            'wheel_mass': 60.8,
            'tyre_stiffness': 310526.3,
            'track': 1.500124,
            'anti_roll_bar': True,
            'mechanism': 'bmw_e90_front',
        },
        'rear': {
            'axle_position': -1.38617,
            'wheel_mass': 75.6,
            'tyre_stiffness': 357859.2,
            'track': 1.4986,
            'anti_roll_bar': True,
            'mechanism': 'bmw_e90_rear',
        },
    },
    'maneuver': {'speed': 20.0, 'horizon': 5.0},
    'road': {'profile': 'iso8608', 'road_class': 'C', 'seed': 1},
    'design': {
        'per_corner': False,
        'k_S1': {'initial': 29770.0, 'lower': 10000.0, 'upper': 60000.0},
        'k_S2': {'initial': 37130.0, 'lower': 10000.0, 'upper': 60000.0},
        'c_S1': {'initial': 4352.5, 'lower': 1000.0, 'upper': 8000.0},
        'c_S2': {'initial': 5810.4, 'lower': 1000.0, 'upper': 8000.0},
        'k_R1': {'initial': 75745.0, 'lower': 0.0, 'upper': 150000.0},
        'k_R2': {'initial': 4030.0, 'lower': 0.0, 'upper': 150000.0},
    },
    'transcription': {'segments': 'auto'},
}

#: The default quarter car: the textbook corner of the active-suspension co-design
#: benchmark (Allison, Guo & Han, "Co-design of an active suspension using simultaneous
#: dynamic optimization", J. Mech. Des. 136(8), 2014): sprung mass 325 kg, unsprung mass
#: 65 kg, tyre rate 232.5 kN/m; a passive spring and damper in a box around common
#: passenger-car values, on an ISO 8608 class C road at 20 m/s.
QUARTER_CAR = {
    'vehicle': {
        'model': 'quarter_car',
        'chassis_mass': 325.0,
        'chassis_pitch_inertia': 0.0,
        'front': {
            'axle_position': 0.0,
            'wheel_mass': 65.0,
            'tyre_stiffness': 232500.0,
            'mechanism': 'double_wishbone',
        },
    },
    'maneuver': {'speed': 20.0, 'horizon': 5.0},
    'road': {'profile': 'iso8608', 'road_class': 'C', 'seed': 1},
    'design': {
        'k_S1': {'initial': 20000.0, 'lower': 5000.0, 'upper': 60000.0},
        'c_S1': {'initial': 1500.0, 'lower': 300.0, 'upper': 6000.0},
    },
    'transcription': {'segments': 'auto'},
}
