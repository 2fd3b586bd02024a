"""Hand-written linear vehicles for the spectral tests (no code shared with suspopt.models).

A rigid chassis (heave ``z``, optionally pitch ``θ`` and roll ``φ``) on corners at ``a``
(ahead of the CG) and ``y`` (left of it); each corner a wheel of mass ``m`` on a tyre
``k_t``, joined to the chassis point ``z_M = z - a θ + y φ`` by a spring ``k`` and a
damper ``c`` (design variables), optionally anti-roll bars across an axle. States
``x = (q, q')`` with ``q = (z[, θ][, φ], z_W1, …)``.
"""

from __future__ import annotations

import numpy as np

from suspopt.spectral import AffineLinearSystem, RoadCorner, affine_system

# the quarter car of the closed-form test
MS, MU, KT = 300.0, 40.0, 200000.0


def quarter_car() -> AffineLinearSystem:
    """x = (z_s, z_u, v_s, v_u); outputs: sprung acceleration, suspension travel
    z_s - z_u, dynamic tyre load k_t (δ - z_u); design k, c."""
    A0 = np.array(
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, -KT / MU, 0.0, 0.0],
        ]
    )
    Ak = np.array(
        [[0, 0, 0, 0], [0, 0, 0, 0], [-1 / MS, 1 / MS, 0, 0], [1 / MU, -1 / MU, 0, 0]], dtype=float
    )
    Ac = np.array(
        [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, -1 / MS, 1 / MS], [0, 0, 1 / MU, -1 / MU]], dtype=float
    )
    B0 = np.array([[0.0], [0.0], [0.0], [KT / MU]])
    C0 = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, -1.0, 0.0, 0.0], [0.0, -KT, 0.0, 0.0]])
    D0 = np.array([[0.0], [0.0], [KT]])
    Ck = np.array([[-1 / MS, 1 / MS, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]], dtype=float)
    Cc = np.array([[0, 0, -1 / MS, 1 / MS], [0, 0, 0, 0], [0, 0, 0, 0]], dtype=float)
    return affine_system(
        {'A': A0, 'B': B0, 'C': C0, 'D': D0},
        {'k': {'A': Ak, 'C': Ck}, 'c': {'A': Ac, 'C': Cc}},
        outputs=('acc', 'travel', 'tyre'),
    )


def rigid_body_car(
    *,
    mass: float,
    a: list[float],
    y: list[float],
    m: list[float],
    kt: list[float],
    pitch_inertia: float | None = None,
    roll_inertia: float | None = None,
    springs: dict[str, list[int]],
    dampers: dict[str, list[int]],
    bars: dict[str, tuple[int, int]] | None = None,
    tracks: list[int] | None = None,
    extra_outputs: tuple[str, ...] = (),
) -> AffineLinearSystem:
    """The chassis-on-corners vehicle (module docstring). ``springs``/``dampers``: design
    name → the corners it acts at; ``bars``: design name → (left, right) corner of an
    anti-roll bar of torsional rate k_R [N m/rad] (force ``k_R (s_L - s_R)/t²``, ``t``
    their lateral distance). Outputs: ``heave_acc``[, ``pitch_acc``][, ``roll_acc``],
    ``travel_i`` (``z_W - z_M``), ``tyre_i`` (``k_t (δ - z_W)``) per corner, and
    ``extra_outputs`` among ``roll`` (the roll angle), ``wheel_0`` (wheel 0's height)."""
    a, y, m, kt = (np.asarray(v, dtype=float) for v in (a, y, m, kt))
    nc = a.size
    body = ['z'] + (['theta'] if pitch_inertia else []) + (['phi'] if roll_inertia else [])
    nb = len(body)
    inertia = (
        [mass]
        + ([pitch_inertia] if pitch_inertia else [])
        + ([roll_inertia] if roll_inertia else [])
    )
    nq = nb + nc
    n = 2 * nq
    # chassis point above each corner as a row over q: z - a θ + y φ
    Lm = np.zeros((nc, nq))
    Lm[:, 0] = 1.0
    if pitch_inertia:
        Lm[:, body.index('theta')] = -a
    if roll_inertia:
        Lm[:, body.index('phi')] = y
    Sq = -Lm.copy()  # deflection s = z_W - z_M over q
    Sq[np.arange(nc), nb + np.arange(nc)] += 1.0
    # generalized force on q of a unit chassis force at each corner: Lmᵀ on the body,
    # minus one on the wheel
    Gf = Lm.T.copy()
    Gf[nb + np.arange(nc), np.arange(nc)] -= 1.0
    Minv = 1.0 / np.concatenate([inertia, m])

    A0 = np.zeros((n, n))
    A0[:nq, nq:] = np.eye(nq)
    A0[nq + nb + np.arange(nc), nb + np.arange(nc)] = -kt / m
    B0 = np.zeros((n, nc))
    B0[nq + nb + np.arange(nc), np.arange(nc)] = kt / m

    names = (
        ['heave_acc']
        + (['pitch_acc'] if pitch_inertia else [])
        + (['roll_acc'] if roll_inertia else [])
    )
    names += [f'travel_{i}' for i in range(nc)] + [f'tyre_{i}' for i in range(nc)]
    names += list(extra_outputs)
    ny = len(names)
    C0 = np.zeros((ny, n))
    D0 = np.zeros((ny, nc))
    for i in range(nc):
        C0[nb + i, :nq] = Sq[i]
        C0[nb + nc + i, nb + i] = -kt[i]
        D0[nb + nc + i, i] = kt[i]
    for k, name in enumerate(extra_outputs):
        row = nb + 2 * nc + k
        if name == 'roll':
            C0[row, body.index('phi')] = 1.0
        elif name == 'wheel_0':
            C0[row, nb] = 1.0
        else:
            raise ValueError(name)

    def term(F_of_x: np.ndarray) -> dict[str, np.ndarray]:
        """A design term whose chassis forces per corner are ``F_of_x`` (nc, n) × value."""
        Aq = (Minv[:, None] * Gf) @ F_of_x  # accelerations over x
        Ai = np.zeros((n, n))
        Ai[nq:] = Aq
        Ci = np.zeros((ny, n))
        Ci[:nb] = Aq[:nb]
        return {'A': Ai, 'C': Ci}

    terms = {}
    for name, corners in springs.items():
        F = np.zeros((nc, n))
        for i in corners:
            F[i, :nq] = Sq[i]
        terms[name] = term(F)
    for name, corners in dampers.items():
        F = np.zeros((nc, n))
        for i in corners:
            F[i, nq:] = Sq[i]
        terms[name] = term(F)
    for name, (left, right) in (bars or {}).items():
        t = y[left] - y[right]
        F = np.zeros((nc, n))
        F[left, :nq] = (Sq[left] - Sq[right]) / t**2
        F[right, :nq] = -F[left, :nq]
        terms[name] = term(F)
    offsets = a.max() - a
    tr = tracks if tracks is not None else [0] * nc
    return affine_system(
        {'A': A0, 'B': B0, 'C': C0, 'D': D0},
        terms,
        outputs=tuple(names),
        corners=tuple(RoadCorner(int(t), float(o)) for t, o in zip(tr, offsets)),
    )


def half_car() -> AffineLinearSystem:
    """Pitch and two wheels, 2.7 m wheelbase; design k1, k2, c1, c2."""
    return rigid_body_car(
        mass=1200.0,
        pitch_inertia=1800.0,
        a=[1.2, -1.5],
        y=[0.0, 0.0],
        m=[40.0, 45.0],
        kt=[2e5, 2e5],
        springs={'k1': [0], 'k2': [1]},
        dampers={'c1': [0], 'c2': [1]},
    )


HALF_CAR_DESIGN = np.array([25000.0, 28000.0, 2000.0, 2200.0])


def full_car(extra_outputs: tuple[str, ...] = ()) -> AffineLinearSystem:
    """Seven degrees of freedom, anti-roll bars on both axles; corners 1L, 1R, 2L, 2R;
    design k1, k2, c1, c2 (per axle), kR1, kR2."""
    return rigid_body_car(
        mass=1400.0,
        pitch_inertia=2400.0,
        roll_inertia=550.0,
        a=[1.35, 1.35, -1.4, -1.4],
        y=[0.75, -0.75, 0.75, -0.75],
        m=[45.0, 45.0, 50.0, 50.0],
        kt=[2.5e5, 2.5e5, 2.5e5, 2.5e5],
        springs={'k1': [0, 1], 'k2': [2, 3]},
        dampers={'c1': [0, 1], 'c2': [2, 3]},
        bars={'kR1': (0, 1), 'kR2': (2, 3)},
        tracks=[0, 1, 0, 1],
        extra_outputs=extra_outputs,
    )


FULL_CAR_DESIGN = np.array([30000.0, 32000.0, 2500.0, 2700.0, 20000.0, 8000.0])
