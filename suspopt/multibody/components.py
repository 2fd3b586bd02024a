"""The multibody suspension module as black-box OpenMDAO components (paper §3.3-3.4).

The optimizer treats the module as an existing solver without adjoints: its partials
come from finite differences only, never from hand-written or automatic derivatives.
Because node ``i``'s outputs depend on node ``i``'s inputs only, the differences are
taken inside ``compute_partials`` by perturbing one input at *all* nodes at once (the
node-wise coloring is known in advance): a full Jacobian costs one batched solver call
per input variable (two with central differences), whatever the number of nodes. The
partials are declared with their node-wise ``rows``/``cols``, so OpenMDAO and the total
sparsity (:mod:`suspopt.driver.sparsity`) see the exact pattern. Only OpenMDAO's public
component API is used.

The module is queried in two steps, as one would query a commercial multibody code:

* :class:`SuspensionKinematicsComp` — position and velocity analysis: wheel travel
  ``z_W`` and its rate → vertical displacement and velocity of the spring point
  (``q^z_U``, eq. 12) and of the wheel (``q^z_W``, eq. 13);
* :class:`SuspensionDynamicsComp` — dynamic analysis: the same state plus the applied
  forces ``F_S`` (``-F_S`` on the spring point) and ``F_T`` (on the contact patch) →
  wheel-travel acceleration from the augmented system (eq. 11) and joint reactions.

Splitting the query keeps the data flow acyclic (the forces depend on the kinematics
outputs, the accelerations on the forces) so no nonlinear solver is needed around the
module.
"""
from __future__ import annotations

import numpy as np
import openmdao.api as om

from suspopt.errors import MultibodyError
from suspopt.multibody.suspension import SuspensionModule


class NodewiseBlackBox(om.ExplicitComponent):
    """An explicit component whose outputs at each node depend only on the inputs at the
    same node, differentiated by finite differences only.

    Subclasses call :meth:`declare_nodewise_fd` in ``setup`` and implement
    :meth:`evaluate` (the black-box call: input arrays in, output arrays out).
    """

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        self.options.declare('module', types=SuspensionModule,
                             desc="this axle's multibody suspension (the black box)")
        self.options.declare('fd_form', default='forward', values=('forward', 'central'))
        self.options.declare('fd_step', default=1e-6, types=float,
                             desc='absolute FD step, in the SI units of every input')

    def declare_nodewise_fd(self, outputs: dict[str, int], inputs: list[str]) -> None:
        """Partials of each output (``outputs[name]`` values per node) w.r.t. each node-wise
        input: one block of ``outputs[name]`` rows per node, in that node's column.

        The step is absolute and the same for every input (in its SI units)."""
        nn = self.options['num_nodes']
        self._fd_outputs, self._fd_inputs = dict(outputs), list(inputs)
        for of, width in outputs.items():
            rows = np.arange(nn * width)
            cols = np.repeat(np.arange(nn), width)
            for wrt in inputs:
                self.declare_partials(of, wrt, rows=rows, cols=cols)

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

    def compute(self, inputs, outputs) -> None:
        values = {k: np.array(inputs[k]) for k in self._fd_inputs}
        out = self._call(values)
        self._last = (self._key(values), out)  # the base point of the next differences
        for name in self._fd_outputs:
            outputs[name] = out[name]

    def compute_partials(self, inputs, partials) -> None:
        """Forward (or central) differences, one input at all nodes per black-box call."""
        base_in = {k: np.array(inputs[k]) for k in self._fd_inputs}
        h, central = self.options['fd_step'], self.options['fd_form'] == 'central'
        base = None
        if not central:
            last = getattr(self, '_last', None)
            base = last[1] if last and last[0] == self._key(base_in) else self._call(base_in)
        for wrt in self._fd_inputs:
            plus = dict(base_in, **{wrt: base_in[wrt] + h})
            up = self._call(plus)
            if central:
                down = self._call(dict(base_in, **{wrt: base_in[wrt] - h}))
                for of in self._fd_outputs:
                    partials[of, wrt] = ((up[of] - down[of]) / (2.0 * h)).ravel()
            else:
                for of in self._fd_outputs:
                    partials[of, wrt] = ((up[of] - base[of]) / h).ravel()


class SuspensionKinematicsComp(NodewiseBlackBox):
    """Position/velocity analysis of one suspension module (black box, FD partials).

    ``z_W`` is the module's independent coordinate (wheel travel, SPEC §3); outputs are
    the vertical displacement and velocity of the spring point (``q^z_U``, eq. 12) and of
    the wheel (``q^z_W``, eq. 13), measured from the reference pose.
    """

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_input('z_W', shape=(nn,), units='m', desc='wheel travel (independent coord.)')
        self.add_input('v_W', shape=(nn,), units='m/s', desc='wheel travel rate')
        self.add_output('q_U', shape=(nn,), units='m', desc='spring point vertical disp.')
        self.add_output('qd_U', shape=(nn,), units='m/s', desc='spring point vertical vel.')
        self.add_output('q_W', shape=(nn,), units='m', desc='wheel vertical displacement')
        self.add_output('qd_W', shape=(nn,), units='m/s', desc='wheel vertical velocity')
        self.declare_nodewise_fd({'q_U': 1, 'qd_U': 1, 'q_W': 1, 'qd_W': 1}, ['z_W', 'v_W'])

    def evaluate(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        kin = self.options['module'].kinematics(values['z_W'], values['v_W'])
        return {'q_U': kin.q_U, 'qd_U': kin.qd_U, 'q_W': kin.q_W, 'qd_W': kin.qd_W}


class SuspensionDynamicsComp(NodewiseBlackBox):
    """Dynamic analysis of one suspension module (black box, FD partials), eq. 11.

    Inputs: wheel travel state and the two applied force magnitudes (``-F_S`` vertical on
    the spring point, ``+F_T`` vertical on the contact patch, SPEC §3). Outputs: the
    wheel-travel acceleration (this replaces the half car's eq. 7/8) and the reaction
    force each joint applies on its first body (from ``λ``).
    """

    def setup(self) -> None:
        nn = self.options['num_nodes']
        nj = self.options['module'].solver.nj
        self.add_input('z_W', shape=(nn,), units='m', desc='wheel travel (independent coord.)')
        self.add_input('v_W', shape=(nn,), units='m/s', desc='wheel travel rate')
        self.add_input('F_S', shape=(nn,), units='N', desc='suspension force (eq. 12)')
        self.add_input('F_T', shape=(nn,), units='N', desc='tyre force (eq. 13)')
        self.add_output('zdd_W', shape=(nn,), units='m/s**2', desc='wheel travel acceleration')
        self.add_output('reactions', shape=(nn, nj, 2), units='N',
                        desc='joint reaction on the first body of each joint, (x, z)')
        self.declare_nodewise_fd({'zdd_W': 1, 'reactions': 2 * nj},
                                 ['z_W', 'v_W', 'F_S', 'F_T'])

    def evaluate(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        module: SuspensionModule = self.options['module']
        kin = module.kinematics(values['z_W'], values['v_W'])
        zdd, reactions = module.dynamics(kin.state, values['F_S'], values['F_T'])
        return {'zdd_W': zdd, 'reactions': reactions}
