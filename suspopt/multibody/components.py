"""The multibody suspension module as black-box OpenMDAO components (paper §3.3-3.4).

The optimizer treats the module as an existing solver without adjoints: its partials
come from finite differences only, never from hand-written or automatic derivatives.
Because the outputs of node ``i`` at corner ``c`` depend on that node's and corner's inputs
only (and on that corner's settings), the differences are taken inside
``compute_partials`` by perturbing one input at *all* nodes and corners at once (the
coloring is known in advance): a full Jacobian costs one batched solver call per input
variable and mechanism (two with central differences), whatever the number of nodes and
corners. The corners that share a mechanism are analysed in one batch. The partials are
declared with their node-wise ``rows``/``cols``, so OpenMDAO and the total sparsity
(:mod:`suspopt.driver.sparsity`) see the exact pattern. Only OpenMDAO's public component
API is used.

The module is queried in two steps, as one would query a commercial multibody code:

* :class:`SuspensionKinematicsComp` — position and velocity analysis: wheel travel ``z_W``
  and its rate → vertical displacement and velocity of the wheel (``q^z_W``, eq. 13);
* :class:`SuspensionDynamicsComp` — dynamic analysis: the same state, the chassis mount's
  vertical motion ``z_M, v_M``, the tyre force ``F_T`` and the spring settings ``k_S, c_S``
  (and, for a spring with curves, its curve parameters: one per-corner input each)
  → wheel-travel acceleration from the augmented system (eq. 11), the spring's vertical
  force on the chassis ``F_S`` (eq. 12 along the spring's line of action) and the joint
  reactions.

Splitting the query keeps the data flow acyclic (the tyre force depends on the kinematics
output, the accelerations on the tyre force), so no nonlinear solver is needed around the
module.

With ``multibody.mount = "chassis"`` the frame moves with the chassis: both queries also
take the mount's pose (``z_M, v_M`` and, with roll, the frame's rotation ``psi_M, w_M``),
and :class:`ChassisMountDynamicsComp` replaces the dynamic analysis: it returns the
module's response (wheel-travel acceleration, the linkage's force and moment on the
chassis, the joints' reactions) at zero mount acceleration and per unit mount
acceleration, which :mod:`suspopt.models.mount` combines with the chassis equations.
"""

from __future__ import annotations

import numpy as np
import openmdao.api as om

from suspopt.errors import MultibodyError
from suspopt.multibody.suspension import RESPONSE, SuspensionModule


class NodewiseBlackBox(om.ExplicitComponent):
    """An explicit component whose outputs at each node and corner depend only on the
    inputs at the same node and corner, differentiated by finite differences only.

    Subclasses call :meth:`declare_nodewise_fd` in ``setup`` and implement
    :meth:`evaluate` (the black-box call: input arrays in, output arrays out).

    With the option ``hessian_frozen`` the driver's exact Hessian
    (:mod:`suspopt.driver.hessian`) leaves out the black box's own curvature:
    differencing its differenced partials again gives noise; its partials then count as
    constant around each point (a Gauss-Newton treatment of the linkage, whose response
    is nearly linear over a suspension's travel; ``docs/codesign.md``).
    """

    @property
    def hessian_frozen(self) -> bool:
        """The Hessian of the Lagrangian treats this component's partials as constant."""
        return bool(self.options['hessian_frozen'])

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        self.options.declare('corners', types=int, default=1)
        self.options.declare(
            'modules',
            types=tuple,
            recordable=False,
            desc='the multibody suspension of every corner (the black box)',
        )
        self.options.declare('fd_form', default='forward', values=('forward', 'central'))
        self.options.declare(
            'fd_step',
            default=1e-6,
            types=float,
            desc='absolute FD step, in the SI units of every input',
        )
        self.options.declare(
            'curve_settings',
            types=tuple,
            default=None,
            allow_none=True,
            desc="the springs' curve parameters that are inputs (default: every one; the "
            "others keep the files' values)",
        )
        self.options.declare(
            'hessian_frozen',
            types=bool,
            default=False,
            desc="the driver's exact Hessian leaves out this black box's curvature",
        )

    def declare_nodewise_fd(
        self,
        outputs: dict[str, int],
        inputs: list[str],
        settings: tuple[str, ...] = (),
        held: tuple[str, ...] = (),
    ) -> None:
        """Partials of each output (``outputs[name]`` values per node and corner) w.r.t.
        each (nodes, corners) input — one block of rows per entry, in that entry's column —
        and w.r.t. each per-corner setting (corners,) — every node of its corner. ``held``:
        inputs the call takes that are not differenced (no module depends on them).

        The step of a node-wise input is absolute and the same for every input (in its SI
        units); a setting's is relative (``fd_step`` times its magnitude, at least 1)."""
        nn, nc = self.options['num_nodes'], self.options['corners']
        n = nn * nc
        self._fd_outputs = dict(outputs)
        self._fd_inputs, self._fd_settings = list(inputs) + list(settings), tuple(settings)
        self._held = tuple(held)
        for of, width in outputs.items():
            rows = np.arange(n * width)
            for wrt in inputs:
                self.declare_partials(of, wrt, rows=rows, cols=np.repeat(np.arange(n), width))
            for wrt in settings:
                self.declare_partials(
                    of, wrt, rows=rows, cols=np.repeat(np.tile(np.arange(nc), nn), width)
                )

    @property
    def _curves(self) -> tuple[str, ...]:
        """The names of the springs' curve parameters that are inputs (beside ``k_S``,
        ``c_S``): every one, or those of the option ``curve_settings``."""
        modules, wanted = self.options['modules'], self.options['curve_settings']
        memo = self.__dict__.get('_curves_memo')
        if memo is None or memo[0] is not modules or memo[1] != wanted:
            names = curve_setting_names(modules)
            memo = (modules, wanted, tuple(n for n in names if wanted is None or n in wanted))
            self.__dict__['_curves_memo'] = memo  # a function of the options: every call
        return memo[2]

    @property
    def _rates(self) -> tuple[str, ...]:
        """``k_S`` and ``c_S`` if some module's spring takes them (a curve replaces the
        linear damper's ``c_S``, a table the rate ``k_S``): the settings differenced."""
        mods = self.options['modules']
        return tuple(n for n in ('k_S', 'c_S') if any(n in m.settings for m in mods))

    def groups(self) -> list[tuple[SuspensionModule, list[int]]]:
        """The corners of each distinct module (analysed in one batch)."""
        out: list[tuple[SuspensionModule, list[int]]] = []
        for c, mod in enumerate(self.options['modules']):
            for m, cols in out:
                if m is mod:
                    cols.append(c)
                    break
            else:
                out.append((mod, [c]))
        return out

    def evaluate(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The black-box call: node-wise inputs by name → outputs by name."""
        raise NotImplementedError

    def _call(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        try:
            return self.evaluate(values)
        except MultibodyError as err:
            raise om.AnalysisError(f'{self.pathname}: {err}') from err

    def _key(self, values) -> bytes:
        return b''.join(np.ascontiguousarray(values[k]).tobytes() for k in self._fd_inputs)

    def _values(self, inputs) -> dict[str, np.ndarray]:
        """The call's inputs: the differenced and the held ones."""
        return {k: np.array(inputs[k]) for k in (*self._fd_inputs, *getattr(self, '_held', ()))}

    def compute(self, inputs, outputs) -> None:
        values = self._values(inputs)
        out = self._call(values)
        self._last = (self._key(values), out)  # the base point of the next differences
        for name in self._fd_outputs:
            outputs[name] = out[name]

    def compute_partials(self, inputs, partials) -> None:
        """Forward (or central) differences, one input at all nodes and corners per
        black-box call."""
        base_in = self._values(inputs)
        step, central = self.options['fd_step'], self.options['fd_form'] == 'central'
        base = None
        if not central:
            last = getattr(self, '_last', None)
            base = last[1] if last and last[0] == self._key(base_in) else self._call(base_in)
        for wrt in self._fd_inputs:
            x = base_in[wrt]
            h = step * np.maximum(1.0, np.abs(x)) if wrt in self._fd_settings else step
            up = self._call(dict(base_in, **{wrt: x + h}))
            low = self._call(dict(base_in, **{wrt: x - h})) if central else base
            assert low is not None
            scale = (2.0 if central else 1.0) * h
            for of in self._fd_outputs:
                partials[of, wrt] = self._scaled(up[of] - low[of], scale)

    def _scaled(self, diff: np.ndarray, h: float | np.ndarray) -> np.ndarray:
        """Differences over the step (a number, or one per corner for a setting), in the
        declared order (node, corner, output values)."""
        nn, nc = self.options['num_nodes'], self.options['corners']
        h = np.reshape(h, (1, nc, 1)) if np.ndim(h) else h
        return (diff.reshape(nn, nc, -1) / h).ravel()


class SuspensionKinematicsComp(NodewiseBlackBox):
    """Position/velocity analysis of every corner's module (black box, FD partials).

    ``z_W`` is a module's independent coordinate (wheel travel, docs/model.md); outputs are the
    vertical displacement and velocity of the wheel (``q^z_W``, eq. 13), measured from the
    reference pose; all (nodes, corners).
    """

    OUTPUTS = ('q_W', 'qd_W')

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('mount', default='ground', values=('ground', 'chassis'))
        self.options.declare(
            'roll', types=bool, default=False, desc='chassis mount: the frames turn with the roll'
        )
        self.options.declare(
            'strut_rate',
            types=bool,
            default=False,
            desc="also the spring-damper's compression rate v_A (an actuator in parallel)",
        )

    @property
    def _analysis_outputs(self) -> tuple[str, ...]:
        return self.OUTPUTS + (('v_A',) if self.options['strut_rate'] else ())

    def setup(self) -> None:
        shape = (self.options['num_nodes'], self.options['corners'])
        self.add_input('z_W', shape=shape, units='m', desc='wheel travel (independent coord.)')
        self.add_input('v_W', shape=shape, units='m/s', desc='wheel travel rate')
        self._pose = mount_pose_inputs(self)
        extra = []
        if self.options['strut_rate'] and self.options['mount'] == 'ground':
            # the spring's chassis end follows the chassis above the corner
            self.add_input('v_M', shape=shape, units='m/s', desc='chassis above the corner')
            extra.append('v_M')
        self.add_output('q_W', shape=shape, units='m', desc='wheel vertical displacement')
        self.add_output('qd_W', shape=shape, units='m/s', desc='wheel vertical velocity')
        if self.options['strut_rate']:
            self.add_output('v_A', shape=shape, units='m/s', desc='spring compression rate')
        self.declare_nodewise_fd(
            {n: 1 for n in self._analysis_outputs}, ['z_W', 'v_W', *self._pose, *extra]
        )

    #: the largest position-constraint violation [m] seen by :meth:`evaluate` since it was
    #: set to a number (the time marching tracks it; None: not tracked, not computed)
    residual_seen: float | None = None

    def evaluate(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        z, v = values['z_W'], values['v_W']
        out = {n: np.empty_like(z) for n in self._analysis_outputs}
        for mod, cols in self.groups():
            kin = mod.kinematics(
                z[:, cols].ravel(), v[:, cols].ravel(), pose=mount_pose(self, values, cols)
            )
            for n in self.OUTPUTS:
                out[n][:, cols] = getattr(kin, n).reshape(z.shape[0], len(cols))
            if self.options['strut_rate']:
                v_M = values['v_M'][:, cols].ravel()
                out['v_A'][:, cols] = mod.strut_rate(kin, v_M).reshape(z.shape[0], len(cols))
            if self.residual_seen is not None:
                residual = mod.constraint_residual(kin.state, kin.pose)
                self.residual_seen = max(self.residual_seen, residual)
        return out

    def constraint_residual(self, values: dict[str, np.ndarray]) -> float:
        """The largest position-constraint violation [m] of the position analysis at
        these inputs."""
        worst = 0.0
        for mod, cols in self.groups():
            kin = mod.kinematics(
                values['z_W'][:, cols].ravel(),
                values['v_W'][:, cols].ravel(),
                pose=mount_pose(self, values, cols),
            )
            worst = max(worst, mod.constraint_residual(kin.state, kin.pose))
        return worst


def curve_setting_names(modules: tuple) -> dict[str, tuple[str, float]]:
    """The springs' curve parameters of ``modules`` (every module's
    :attr:`~suspopt.multibody.suspension.SuspensionModule.settings` besides ``k_S``,
    ``c_S``), each with its units and default (the first file's value); none for linear
    springs."""
    out: dict[str, tuple[str, float]] = {}
    for mod in modules:
        for n in mod.settings:
            if n not in ('k_S', 'c_S') and n not in out:
                out[n] = (mod.setting_units[n], mod.unit.scalar_parameters()[n])
    return out


def curve_setting_inputs(comp: NodewiseBlackBox) -> tuple[str, ...]:
    """Add the per-corner inputs of the springs' curve parameters
    (:func:`curve_setting_names`, those of the option ``curve_settings``); their names."""
    nc = comp.options['corners']
    names = curve_setting_names(comp.options['modules'])
    wanted = comp.options['curve_settings']
    for n, (units, default) in names.items():
        if wanted is None or n in wanted:
            comp.add_input(n, val=default, shape=(nc,), units=units, desc='spring curve parameter')
    return comp._curves


def curve_settings(
    mod: SuspensionModule, values: dict[str, np.ndarray], names: tuple[str, ...], cols, nn: int
) -> dict[str, np.ndarray] | None:
    """The curve settings of the corners ``cols`` that ``mod``'s spring has, per state."""
    out = {n: np.tile(values[n][cols], nn) for n in names if n in mod.settings}
    return out or None


def mount_pose_inputs(comp: NodewiseBlackBox) -> list[str]:
    """Add the mount pose inputs of a chassis-mounted module; their names."""
    if comp.options['mount'] != 'chassis':
        return []
    shape = (comp.options['num_nodes'], comp.options['corners'])
    names = [('z_M', 'm', 'chassis above the corner'), ('v_M', 'm/s', 'its vertical velocity')]
    if comp.options['roll']:
        names += [('psi_M', 'rad', 'frame rotation'), ('w_M', 'rad/s', 'its rate')]
    for name, units, desc in names:
        comp.add_input(name, shape=shape, units=units, desc=desc)
    return [n for n, _, _ in names]


def mount_pose(comp: NodewiseBlackBox, values: dict[str, np.ndarray], cols: list[int]):
    """``(z_M, v_M, ψ, ψ̇)`` of the corners ``cols``, flattened (None: ground mount)."""
    if comp.options['mount'] != 'chassis':
        return None
    flat = {k: values[k][:, cols].ravel() for k in ('z_M', 'v_M')}
    zero = np.zeros_like(flat['z_M'])
    roll = comp.options['roll']
    return (
        flat['z_M'],
        flat['v_M'],
        values['psi_M'][:, cols].ravel() if roll else zero,
        values['w_M'][:, cols].ravel() if roll else zero,
    )


class SuspensionDynamicsComp(NodewiseBlackBox):
    """Dynamic analysis of every corner's module (black box, FD partials), eq. 11.

    Inputs: the wheel-travel state, the chassis mount's vertical displacement and velocity
    ``z_M, v_M`` above the corner, the tyre force ``F_T`` (on the contact patch) and the
    corner's spring rate and damping ``k_S, c_S`` (the suspension spring-damper of the
    mechanism, coupled to the chassis along its line of action). Outputs: the
    wheel-travel acceleration (this replaces the half car's eq. 7/8), the spring's
    vertical force on the chassis ``F_S`` (eq. 12 generalized) and the reaction force each
    joint applies on its first body (from ``λ``; (nodes, corners, joints, 2), zero-padded
    to the mechanism with the most joints).
    """

    NODE_INPUTS = ('z_W', 'v_W', 'z_M', 'v_M', 'F_T')

    def initialize(self) -> None:
        super().initialize()
        self.options.declare(
            'actuator',
            types=bool,
            default=False,
            desc="an actuator force F_A along the spring-damper's line (node-wise input)",
        )

    @property
    def _node_inputs(self) -> tuple[str, ...]:
        return self.NODE_INPUTS + (('F_A',) if self.options['actuator'] else ())

    @property
    def _nj(self) -> int:
        return max(m.solver.nj for m in self.options['modules'])

    def setup(self) -> None:
        nn, nc = self.options['num_nodes'], self.options['corners']
        nj = self._nj
        shape = (nn, nc)
        self.add_input('z_W', shape=shape, units='m', desc='wheel travel (independent coord.)')
        self.add_input('v_W', shape=shape, units='m/s', desc='wheel travel rate')
        self.add_input('z_M', shape=shape, units='m', desc='chassis above the corner')
        self.add_input('v_M', shape=shape, units='m/s', desc='its vertical velocity')
        self.add_input('F_T', shape=shape, units='N', desc='tyre force (eq. 13)')
        if self.options['actuator']:
            self.add_input('F_A', shape=shape, units='N', desc='actuator force, extending')
        self.add_input('k_S', shape=(nc,), units='N/m', desc='spring rate per corner')
        self.add_input('c_S', shape=(nc,), units='N*s/m', desc='damping per corner')
        curve_setting_inputs(self)
        self.add_output('zdd_W', shape=shape, units='m/s**2', desc='wheel travel acceleration')
        self.add_output('F_S', shape=shape, units='N', desc='spring force on the chassis, up')
        self.add_output(
            'reactions',
            shape=(nn, nc, nj, 2),
            units='N',
            desc='joint reaction on the first body of each joint, (x, z)',
        )
        self.declare_nodewise_fd(
            {'zdd_W': 1, 'F_S': 1, 'reactions': 2 * nj},
            list(self._node_inputs),
            settings=(*self._rates, *self._curves),
            held=tuple(n for n in ('k_S', 'c_S') if n not in self._rates),
        )

    def evaluate(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        z = values['z_W']
        nn = z.shape[0]
        zdd, F_S = np.empty_like(z), np.empty_like(z)
        reactions = np.zeros(z.shape + (self._nj, 2))
        for mod, cols in self.groups():
            flat = {k: values[k][:, cols].ravel() for k in self._node_inputs}
            k_S = np.tile(values['k_S'][cols], nn)
            c_S = np.tile(values['c_S'][cols], nn)
            kin = mod.kinematics(flat['z_W'], flat['v_W'])
            acc, force, reac = mod.dynamics(
                kin.state,
                flat['z_M'],
                flat['v_M'],
                k_S,
                c_S,
                flat['F_T'],
                settings=curve_settings(mod, values, self._curves, cols, nn),
                **({'actuator': flat['F_A']} if 'F_A' in flat else {}),
            )
            zdd[:, cols] = acc.reshape(nn, len(cols))
            F_S[:, cols] = force.reshape(nn, len(cols))
            if reac is None:  # a module that does not give the joints' reactions
                reactions[:, cols] = np.nan
            else:
                reactions[:, cols, : reac.shape[1]] = reac.reshape(nn, len(cols), -1, 2)
        return {'zdd_W': zdd, 'F_S': F_S, 'reactions': reactions}


class ChassisMountDynamicsComp(NodewiseBlackBox):
    """Dynamic analysis of every corner's chassis-mounted module (black box, FD partials).

    Inputs: the wheel-travel state, the mount's pose (``z_M, v_M`` [, ``psi_M, w_M``]),
    the tyre force ``F_T`` and the settings ``k_S, c_S``. Outputs: ``response`` (nodes,
    corners, blocks, entries): the entries of
    :data:`~suspopt.multibody.suspension.RESPONSE` then every joint's reaction (x, z) on
    its first body (zero-padded to the mechanism with the most joints), in blocks at zero
    mount acceleration and per unit mount acceleration (vertical of P [, rotation]); and
    ``F_S``, the spring's vertical force on its chassis end (no acceleration term).
    """

    def initialize(self) -> None:
        super().initialize()
        self.options.declare(
            'roll', types=bool, default=False, desc='the frames turn with the roll'
        )
        self.options.declare('mount', default='chassis', values=('chassis',))
        self.options.declare(
            'actuator',
            types=bool,
            default=False,
            desc="an actuator force F_A along the spring-damper's line (node-wise input)",
        )

    @property
    def width(self) -> int:
        return len(RESPONSE) + 2 * max(m.n_joints for m in self.options['modules'])

    @property
    def _blocks(self) -> int:
        return 3 if self.options['roll'] else 2

    def setup(self) -> None:
        nn, nc = self.options['num_nodes'], self.options['corners']
        shape = (nn, nc)
        self.add_input('z_W', shape=shape, units='m', desc='wheel travel (independent coord.)')
        self.add_input('v_W', shape=shape, units='m/s', desc='wheel travel rate')
        pose = mount_pose_inputs(self)
        self.add_input('F_T', shape=shape, units='N', desc='tyre force (eq. 13)')
        actuator = ['F_A'] if self.options['actuator'] else []
        if actuator:
            self.add_input('F_A', shape=shape, units='N', desc='actuator force, extending')
        self.add_input('k_S', shape=(nc,), units='N/m', desc='spring rate per corner')
        self.add_input('c_S', shape=(nc,), units='N*s/m', desc='damping per corner')
        curve_setting_inputs(self)
        self.add_output(
            'response',
            shape=(nn, nc, self._blocks, self.width),
            units=None,
            desc='module response (SI units), blocks: a = 0, per unit a',
        )
        self.add_output('F_S', shape=shape, units='N', desc='spring force on its chassis end')
        self.declare_nodewise_fd(
            {'response': self._blocks * self.width, 'F_S': 1},
            ['z_W', 'v_W', *pose, 'F_T', *actuator],
            settings=(*self._rates, *self._curves),
            held=tuple(n for n in ('k_S', 'c_S') if n not in self._rates),
        )

    def evaluate(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        z = values['z_W']
        nn = z.shape[0]
        resp = np.zeros(z.shape + (self._blocks, self.width))
        F_S = np.empty_like(z)
        for mod, cols in self.groups():
            kin = mod.kinematics(
                z[:, cols].ravel(),
                values['v_W'][:, cols].ravel(),
                pose=mount_pose(self, values, cols),
            )
            R, force = mod.mount_response(
                kin,
                np.tile(values['k_S'][cols], nn),
                np.tile(values['c_S'][cols], nn),
                values['F_T'][:, cols].ravel(),
                rotation=self.options['roll'],
                settings=curve_settings(mod, values, self._curves, cols, nn),
                **(
                    {'actuator': values['F_A'][:, cols].ravel()} if self.options['actuator'] else {}
                ),
            )
            resp[:, cols, :, : R.shape[2]] = R.reshape(nn, len(cols), self._blocks, -1)
            F_S[:, cols] = force.reshape(nn, len(cols))
        return {'response': resp, 'F_S': F_S}
