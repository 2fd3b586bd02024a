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
* centre of gravity 0.512 m above the ground: Chrono's chassis centre of mass is
  0.206232 m above its reference frame, which holds the wheel centres (``BMW_E90_Vehicle``
  places both axles and the spindles at its height), plus the tyres' loaded radius there:
  free radius 0.3186 m (``BMW_E90_TMsimpleTireFront``/``Rear``) less the static deflection
  under each tyre's static load (4151 / 4257 N on 310.5 / 357.9 kN/m: 0.3052 / 0.3067 m),
  interpolated at the CG (0.3060 m);
* roll centres 0.0050 m (front) and 0.0523 m (rear) above the ground: the kinematic roll
  centres of the two linkages below at their reference pose (``suspopt kinematics
  bmw_e90_front``, ``bmw_e90_rear``); with them the initial design rolls 3.34 deg/g,
  the 2.0 deg at 0.6 g that Chrono's suspension was fit to (SAE 2007-01-0817);
* the driver's seat 0.271 m ahead of the CG (Chrono's ``m_driverCsys`` at x = -1.1 m
  from the front axle, the CG at -1.371 m) and 0.37 m left of the centre line: a
  left-hand-drive seat centre chosen here (Chrono's y = 0.7 m is a viewpoint by the door,
  not a seat);
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

The engineering study it ships (``docs/metrics.md``, "Constraints"): ride comfort at the
driver's seat (ISO 2631-1 Wk) against road holding (the dynamic tyre loads), half each,
subject to

* suspension travel within ±50 mm of the static position at every corner: Chrono's front
  strut meets its bump and rebound stops 0.05 m of spring travel either side of its
  design length (``BMW_E90_MacPhersonStrut``: ``enable_stops``), 0.0516 m at the wheel
  through its 0.969 motion ratio; the rear's stops (0.05 m at a 0.549 ratio, 0.091 m at
  the wheel) are farther, so the front's bound, rounded down, serves every corner: the
  stops are not in the model, and off them it is valid;
* every tyre in contact at every instant (``margin = 0``: the total tyre load, static
  plus dynamic, stays >= 0; the linear tyre model is valid only there): on this rough
  road at 20 m/s even the initial design lifts a rear wheel, and IPOPT finds no design
  of the box that keeps a 20 % reserve, so the reserve is left to the engineer;
* a roll gradient of at most 3.5 deg/g (the production car's 3.34 deg/g, above, plus a
  5 % allowance) with the front axle carrying 55-75 % of the roll stiffness: an
  understeering balance (the front's share of the weight is 50 %; Chrono notes the car
  understeers; its own share here is 67 %).
"""

from __future__ import annotations

BMW_E90 = {
    'vehicle': {
        'model': 'full_car',
        'chassis_mass': 1442.1,
        'chassis_pitch_inertia': 2487.0,
        'chassis_roll_inertia': 572.0,
        'cg_height': 0.512,
        'front': {
            'axle_position': 1.371,
            'wheel_mass': 60.8,
            'tyre_stiffness': 310526.3,
            'track': 1.500124,
            'anti_roll_bar': True,
            'mechanism': 'bmw_e90_front',
            'roll_centre_height': 0.0050,
        },
        'rear': {
            'axle_position': -1.38617,
            'wheel_mass': 75.6,
            'tyre_stiffness': 357859.2,
            'track': 1.4986,
            'anti_roll_bar': True,
            'mechanism': 'bmw_e90_rear',
            'roll_centre_height': 0.0523,
        },
    },
    'comfort': {'seats': [{'name': 'driver', 'x': 0.271, 'y': 0.37}]},
    'objective': {'weights': {'comfort': 0.5, 'tyre_load': 0.5}},
    'constraints': {
        'travel': {'enabled': True, 'bump': 0.05, 'rebound': 0.05},
        'tyre_contact': {'enabled': True, 'margin': 0.0},
        'roll_gradient': {'enabled': True, 'max': 3.5, 'front_share': [0.55, 0.75]},
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
