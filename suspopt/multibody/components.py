"""The multibody suspension module as black-box OpenMDAO components (paper §3.3-3.4).

The optimizer treats the module as an existing solver without adjoints: these
components declare NO analytic partials. Their partials come from OpenMDAO's finite
differences with partial coloring. Because node ``i``'s outputs depend on node ``i``'s
inputs only, the coloring is known in advance and is declared (no FD probing to detect
it), so a full FD Jacobian costs one batched solver call per input variable, whatever
the number of nodes.

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
from openmdao.utils.coloring import _ColSparsityJac

from suspopt.errors import MultibodyError
from suspopt.multibody.suspension import SuspensionModule


class NodewiseBlackBox(om.ExplicitComponent):
    """An explicit component whose partials come from finite differences only and whose
    outputs at each node depend only on the inputs at the same node.

    Subclasses call :meth:`declare_nodewise_fd` in ``setup``; the FD partial coloring is
    then built from that declared structure instead of being detected by perturbation
    (OpenMDAO's default probes several full FD Jacobians, and at an all-zero start it can
    miss real nonzeros).
    """

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        self.options.declare('module', types=SuspensionModule,
                             desc="this axle's multibody suspension (the black box)")
        self.options.declare('fd_form', default='forward', values=('forward', 'central'))
        self.options.declare('fd_step', default=1e-6, types=float,
                             desc='absolute FD step, in the SI units of every input')

    def declare_nodewise_fd(self, outputs: dict[str, int], inputs: list[str]) -> None:
        """FD partials of each output (with ``outputs[name]`` values per node) w.r.t. each
        node-wise scalar input, with per-node block sparsity and a fixed coloring.

        The step is absolute and the same for every input: OpenMDAO's colored FD takes
        the step of the first input for all columns, so a relative step sized for the
        forces (~1e-3 N) would also be applied to the wheel travel (in m).
        """
        nn = self.options['num_nodes']
        form, step = self.options['fd_form'], self.options['fd_step']
        self._nodewise = {}
        self.declare_coloring(wrt=inputs, method='fd', form=form, step=step,
                              show_summary=False)
        for of, width in outputs.items():
            rows = np.arange(nn * width)
            cols = np.repeat(np.arange(nn), width)
            for wrt in inputs:
                self.declare_partials(of, wrt, rows=rows, cols=cols, method='fd', form=form,
                                      step=step, step_calc='abs')
                self._nodewise[of, wrt] = (rows, cols)

    def compute_fd_sparsity(self, method: str = 'fd', num_full_jacs: int = 2,
                            perturb_size: float = 1e-9):
        """The declared node-wise sparsity; no FD evaluation is spent on detecting it."""
        jac = _ColSparsityJac(self)
        prefix = self.pathname + '.' if self.pathname else ''
        ofs = [(name[len(prefix):], start, end) for name, start, end, *_ in self._get_jac_ofs()]
        col = np.zeros(jac.shape[0])
        for wrt_abs, wstart, wend, *_ in self._get_jac_wrts(self._coloring_info.wrt_matches):
            wrt = wrt_abs[len(prefix):]
            for k in range(wend - wstart):
                col[:] = 0.0
                for of, ostart, _ in ofs:
                    pattern = self._nodewise.get((of, wrt))
                    if pattern is not None:
                        rows, cols = pattern
                        col[ostart + rows[cols == k]] = 1.0
                jac.set_col(self, wstart + k, col)
        return jac.get_sparsity()


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

    def compute(self, inputs, outputs) -> None:
        try:
            kin = self.options['module'].kinematics(inputs['z_W'], inputs['v_W'])
        except MultibodyError as err:
            raise om.AnalysisError(f'{self.pathname}: {err}') from err
        outputs['q_U'] = kin.q_U
        outputs['qd_U'] = kin.qd_U
        outputs['q_W'] = kin.q_W
        outputs['qd_W'] = kin.qd_W


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

    def compute(self, inputs, outputs) -> None:
        module: SuspensionModule = self.options['module']
        try:
            kin = module.kinematics(inputs['z_W'], inputs['v_W'])
            outputs['zdd_W'], outputs['reactions'] = module.dynamics(
                kin.state, inputs['F_S'], inputs['F_T'])
        except MultibodyError as err:
            raise om.AnalysisError(f'{self.pathname}: {err}') from err
