"""The chassis with chassis-mounted multibody modules (``multibody.mount = "chassis"``).

Each module's frame moves with the chassis at its corner
(:mod:`suspopt.multibody.suspension`) and the chassis receives the linkage's reactions on
the frame instead of the spring force alone. Those depend on the mount's acceleration,
which the chassis equations give: the loop is closed here in closed form, node by node,
because every module reports its response at zero mount acceleration and per unit mount
acceleration (it is affine in it). :class:`ChassisMountComp` is the chassis (eqs. 5-6 and
roll) with those reactions; :class:`MountResponseComp` evaluates the modules' outputs at
the solved accelerations; :class:`MountRotationComp` turns each frame with the roll.
"""

from __future__ import annotations

import numpy as np

from suspopt.models import equations as eq
from suspopt.models.base import NodeComponent

#: index of the entries of a module response (suspopt.multibody.suspension.RESPONSE)
ZDD_W, F_Z, M_P, F_X, JOINTS = 0, 1, 2, 3, 4


class MountRotationComp(NodeComponent):
    """Each corner's frame rotation in its front view: ``ψ = side · φ_C``, ``ψ̇ = side · p_C``
    (:func:`~suspopt.models.equations.mount_rotation`)."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('side', types=np.ndarray, desc='+1 left, -1 right, per corner')

    def setup(self) -> None:
        nn, nc = self._shape
        side = np.tile(self.options['side'].astype(float), nn)
        for pos, vel in (('phi_C', 'psi_M'), ('p_C', 'w_M')):
            units = 'rad' if pos == 'phi_C' else 'rad/s'
            self.add_input(pos, shape=(nn,), units=units)
            self.add_output(vel, shape=(nn, nc), units=units, desc='frame rotation (rate)')
            self._spread_partials(vel, pos, val=side)

    def evaluate(self, inputs):
        side = self.options['side']
        return {
            'psi_M': eq.mount_rotation(inputs['phi_C'], side),
            'w_M': eq.mount_rotation(inputs['p_C'], side),
        }


class _MountComp(NodeComponent):
    """Shared options: where the corners are, and the modules' response layout."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('a', types=np.ndarray, desc='corner positions ahead of the CG [m]')
        self.options.declare('y', types=np.ndarray, desc='corner positions left of the CG [m]')
        self.options.declare('side', types=np.ndarray, desc='+1 left, -1 right, 0 centre')
        self.options.declare('roll', types=bool, default=False, desc='the chassis rolls')
        self.options.declare('pitch', types=bool, default=True, desc='the chassis pitches')
        self.options.declare('width', types=int, desc='entries of a module response')

    @property
    def _L(self) -> np.ndarray:
        o = self.options
        return eq.mount_map(o['a'], o['y'], o['side'], o['roll'], o['pitch'])

    @property
    def _chassis(self) -> tuple[tuple[str, str], ...]:
        o = self.options
        return (
            (('zdd_C', 'm/s**2'),)
            + ((('thdd_C', 'rad/s**2'),) if o['pitch'] else ())
            + ((('phidd_C', 'rad/s**2'),) if o['roll'] else ())
        )

    def _add_response(self) -> tuple[int, int]:
        nn, nc = self._shape
        blocks = 1 + self._L.shape[1]
        self.add_input(
            'response',
            shape=(nn, nc, blocks, self.options['width']),
            units=None,
            desc='module responses: at zero mount acceleration, per unit (SI)',
        )
        return blocks, self.options['width']

    def _flat(self, n, c, b, r) -> np.ndarray:
        """Flat index of response entries (node, corner, block, entry)."""
        nc = self.options['corners']
        blocks, width = 1 + self._L.shape[1], self.options['width']
        return ((np.asarray(n) * nc + c) * blocks + b) * width + r


class ChassisMountComp(_MountComp):
    """The chassis with chassis-mounted modules: heave, pitch (eqs. 5-6) and roll with
    the modules' generalized mount forces, the loop through the mount acceleration solved
    per node (:func:`~suspopt.models.equations.chassis_mount_accelerations`)."""

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('M', types=float, desc='chassis (sprung) mass [kg]')
        self.options.declare('I', types=float, default=1.0, desc='pitch inertia [kg m^2]')
        self.options.declare('I_x', types=float, default=1.0, desc='roll inertia [kg m^2]')
        self.options.declare(
            'forces',
            types=tuple,
            default=(),
            desc='further vertical forces on the chassis per corner [N]',
        )

    def setup(self) -> None:
        nn, nc = self._shape
        self._add_response()
        nu = self._L.shape[1]
        for name in self.options['forces']:
            self.add_input(name, shape=(nn, nc), units='N', desc='force on the chassis, up')
        n, c, u = (
            a.ravel()
            for a in np.meshgrid(np.arange(nn), np.arange(nc), np.arange(nu), indexing='ij')
        )
        # F0 entries (n, c, u), then G entries (n, c, u, v) for each v
        cols = [self._flat(n, c, 0, 1 + u)] + [self._flat(n, c, 1 + v, 1 + u) for v in range(nu)]
        self._resp_cols = np.concatenate(cols)
        rows = np.tile(n, 1 + nu)
        for name, units in self._chassis:
            self.add_output(name, shape=(nn,), units=units)
            self.declare_partials(name, 'response', rows=rows, cols=self._resp_cols)
            for f in self.options['forces']:
                self._sum_partials(name, f)

    def _solve(self, inputs):
        o = self.options
        R = inputs['response']
        nu = self._L.shape[1]
        F0, G = eq.mount_forces(R, nu)
        F_R = sum(inputs[f] for f in o['forces']) if o['forces'] else np.zeros(R.shape[:2])
        inertia = [o['M']] + ([o['I']] if o['pitch'] else []) + ([o['I_x']] if o['roll'] else [])
        return eq.chassis_mount_accelerations(F0, G, F_R, self._L, inertia), G, inertia

    def evaluate(self, inputs):
        acc, _, _ = self._solve(inputs)
        return {name: acc[:, k] for k, (name, _) in enumerate(self._chassis)}

    def compute_partials(self, inputs, partials) -> None:
        acc, G, inertia = self._solve(inputs)
        L = self._L
        nu = L.shape[1]
        A = np.diag(inertia) - np.einsum('cuk,ncuv,cvl->nkl', L, G, L)
        W = np.einsum('nkl,cul->ncku', np.linalg.inv(A), L)  # A⁻¹ L_cᵀ
        a_M = eq.mount_accelerations(acc, L)  # (n, c, v)
        for k, (name, _) in enumerate(self._chassis):
            Wk = W[:, :, k, :]  # (n, c, u)
            vals = [Wk.ravel()] + [(Wk * a_M[:, :, v : v + 1]).ravel() for v in range(nu)]
            partials[name, 'response'] = np.concatenate(vals)
            for f in self.options['forces']:
                partials[name, f] = W[:, :, k, 0].ravel()


class MountResponseComp(_MountComp):
    """The modules' outputs at the solved mount accelerations
    (:func:`~suspopt.models.equations.mount_response`): the wheel-travel acceleration
    ``zdd_W`` (the state rate), the vertical force on the chassis ``F_M`` and every joint's
    reaction on its first body."""

    def _targets(self, nn: int) -> dict[str, tuple[tuple[int, ...], str, list[int]]]:
        """Each output's shape at ``nn`` nodes, units and entries of the response."""
        nc, width = self.options['corners'], self.options['width']
        nj = (width - JOINTS) // 2
        return {
            'zdd_W': ((nn, nc), 'm/s**2', [ZDD_W]),
            'F_M': ((nn, nc), 'N', [F_Z]),
            'reactions': ((nn, nc, nj, 2), 'N', list(range(JOINTS, width))),
        }

    def setup(self) -> None:
        nn, nc = self._shape
        blocks, width = self._add_response()
        for name, units in self._chassis:
            self.add_input(name, shape=(nn,), units=units)
        for out, (shape, units, entries) in self._targets(nn).items():
            self.add_output(out, shape=shape, units=units)
            e = np.asarray(entries)
            n, c, j = (
                a.ravel()
                for a in np.meshgrid(np.arange(nn), np.arange(nc), np.arange(e.size), indexing='ij')
            )
            rows = np.arange(n.size)
            self.declare_partials(
                out,
                'response',
                rows=np.tile(rows, blocks),
                cols=np.concatenate([self._flat(n, c, b, e[j]) for b in range(blocks)]),
            )
            for name, _ in self._chassis:
                self.declare_partials(out, name, rows=rows, cols=n)

    def _a_M(self, inputs) -> np.ndarray:
        acc = np.stack([inputs[name] for name, _ in self._chassis], -1)
        return eq.mount_accelerations(acc, self._L)

    def evaluate(self, inputs):
        r = eq.mount_response(inputs['response'], self._a_M(inputs))
        return {
            out: r[:, :, entries].reshape(shape)
            for out, (shape, _, entries) in self._targets(r.shape[0]).items()
        }

    def compute_partials(self, inputs, partials) -> None:
        R = inputs['response']
        a_M, L = self._a_M(inputs), self._L
        for out, (_, _, entries) in self._targets(R.shape[0]).items():
            Ru = R[:, :, 1:, entries]  # (n, c, u, j)
            ones = np.ones(Ru.shape[:2] + (len(entries),))
            partials[out, 'response'] = np.concatenate(
                [ones.ravel()]
                + [
                    np.broadcast_to(a_M[:, :, v, None], ones.shape).ravel()
                    for v in range(L.shape[1])
                ]
            )
            for k, (name, _) in enumerate(self._chassis):
                partials[out, name] = np.einsum('ncuj,cu->ncj', Ru, L[:, :, k]).ravel()
