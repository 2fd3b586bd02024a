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

import time

import numpy as np
import openmdao.api as om
from openmdao.approximation_schemes.finite_difference import FiniteDifference
from openmdao.jacobians.dictionary_jacobian import _CheckingJacobian
from openmdao.jacobians.subjac import OMCOOSubjac
from openmdao.utils.coloring import Coloring, _ColSparsityJac, _tol_sweep
from scipy.sparse import coo_matrix

from suspopt.errors import MultibodyError
from suspopt.multibody.suspension import SuspensionModule


class _NodewiseFiniteDifference(FiniteDifference):
    """OpenMDAO's finite differences, unchanged (same perturbations, same runs of the black
    box), except how a colored run's result reaches the sparse sub-Jacobians: OpenMDAO
    sets it column by column, each column searching the whole sub-Jacobian (quadratic in
    the number of nodes: ~1.4 s per mixed-fidelity solve at 400 nodes); with the
    node-wise coloring one color is all nodes of one input, so the result is the
    sub-Jacobians' data in one gather."""

    _per_color = False

    def compute_approximations(self, system, jac) -> None:
        if isinstance(jac, _CheckingJacobian) or not self._wrt_meta:
            return super().compute_approximations(system, jac)
        if jac._col_mapper is None:
            jac._setup_index_maps(system)
        self._per_color = True
        try:
            for item in self.compute_approx_col_iter(
                    system, under_cs=system._outputs._under_complex_step):
                if isinstance(item[1], dict):
                    self._set_color(system, jac, *item)
                else:
                    jac.set_col(system, *item)
        finally:
            self._per_color = False

    def _colored_column_iter(self, system, colored_approx_groups):
        if not self._per_color or system._num_par_fd > 1:
            yield from super()._colored_column_iter(system, colored_approx_groups)
            return
        results_array = system._residuals.asarray(copy=True)
        for data, jcols, vec_ind_list, nzrows, seed_vars in colored_approx_groups:
            with system._relevance.seeds_active(fwd_seeds=seed_vars):
                result = self._run_point(system, vec_ind_list, data, results_array, False)
            result = self._transform_result(result) * self._get_multiplier(data)
            yield jcols, {'result': result.copy(), 'nzrows': nzrows}

    @staticmethod
    def _set_color(system, jac, jcols, color) -> None:
        result, mapper = color['result'], jac._col_mapper
        wrt, first = mapper.index2key_rel(jcols[0])
        last_wrt, last = mapper.index2key_rel(jcols[-1])
        contiguous = last_wrt == wrt and first == 0 and last == len(jcols) - 1
        for of, start, end, *_ in system._get_jac_ofs():
            sub = jac._subjacs.get((of, wrt))
            if sub is None:
                continue
            if (contiguous and isinstance(sub, OMCOOSubjac)
                    and sub.info['shape'][1] == len(jcols)):
                sub.info['val'][:] = result[start + sub.rows]
            else:  # general case: OpenMDAO's own per-column assignment
                for jcol, rows in zip(jcols, color['nzrows']):
                    col = np.zeros(len(result))
                    col[rows] = result[rows]
                    jac.set_col(system, jcol, col)
                return


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

    def _get_approx_scheme(self, method):
        if method == 'fd' and 'fd' not in self._approx_schemes:
            self._approx_schemes['fd'] = _NodewiseFiniteDifference()
        return super()._get_approx_scheme(method)

    def _get_jacobian(self, use_relevance: bool = True):
        """Keep this component's Jacobian across relevance changes.

        OpenMDAO rebuilds a component's Jacobian whenever the relevance graph changes, and
        the driver's linearization and its two total-derivative solves per iterate each
        have their own graph; for a finite-differenced component the rebuild also
        re-initializes the colored FD (together ~0.1 s per mixed-fidelity solve). These
        partials do not depend on relevance: every FD run perturbs all nodes of an input
        and yields every output."""
        jac = self._jacobian
        if jac is not None and not isinstance(jac, _ColSparsityJac):
            self._relevance_changed()  # keep OpenMDAO's bookkeeping current
            return jac
        return super()._get_jacobian(use_relevance)

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
        info = self._coloring_info
        prefix = self.pathname + '.' if self.pathname else ''
        ofs = [(name[len(prefix):], start, end) for name, start, end, *_ in self._get_jac_ofs()]
        wrts = self._get_jac_wrts(info.wrt_matches)
        rows, cols = [np.zeros(0, dtype=int)], [np.zeros(0, dtype=int)]
        for wrt_abs, wstart, *_ in wrts:
            for of, ostart, _ in ofs:
                pattern = self._nodewise.get((of, wrt_abs[len(prefix):]))
                if pattern is not None:
                    rows.append(ostart + pattern[0])
                    cols.append(wstart + pattern[1])
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        shape = (ofs[-1][2] if ofs else 0, wrts[-1][2] if wrts else 0)
        # the metadata OpenMDAO's own detection reports, for a pattern of exact nonzeros
        sp_info = _tol_sweep(np.ones(rows.size), info.tol, info.orders)
        sp_info.update(J_shape=shape, nz_entries=rows.size)
        return coo_matrix((np.ones(rows.size, dtype=bool), (rows, cols)), shape=shape), sp_info

    def _compute_coloring(self, recurse=False, **overrides):
        """The FD partial coloring, built from the known structure: one color per input
        variable (all its nodes perturbed at once). OpenMDAO's general graph coloring of
        the same sparsity takes ~0.5 s per component at 400 nodes, on every new problem."""
        info = self._coloring_info
        info.update(overrides)
        if info['method'] is None and self._approx_schemes:
            info['method'] = list(self._approx_schemes)[0]
        if info.coloring is None and info.static is None:
            info.dynamic = True
        t0 = time.perf_counter()
        sparsity, sp_info = self.compute_sparsity()
        coo = sparsity.tocoo()
        order = np.lexsort((coo.row, coo.col))
        rows, cols = coo.row[order], coo.col[order]
        ncols = sparsity.shape[1]
        bounds = np.searchsorted(cols, np.arange(ncols + 1))
        groups = [list(range(start, end)) for _, start, end, *_ in
                  self._get_jac_wrts(info.wrt_matches)]
        for group in groups:  # a color's columns must not share a row
            grows = rows[bounds[group[0]]:bounds[group[-1] + 1]] if group else rows[:0]
            if np.unique(grows).size != grows.size:
                raise RuntimeError(f'{self.msginfo}: outputs are not node-wise in the inputs')
        coloring = Coloring(sparsity=sparsity)
        row_list = rows.tolist()
        coloring._fwd = (groups, [row_list[a:b] or None
                                  for a, b in zip(bounds[:-1], bounds[1:])])
        coloring._meta['coloring_time'] = time.perf_counter() - t0
        coloring._resolver = self._resolver
        if not self._finalize_coloring(coloring, info, sp_info, time.perf_counter() - t0):
            return [None]
        return [coloring]


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
