"""The vehicle models as ODE groups for Dymos (paper §3.1 and §3.3).

:class:`HalfCarODE` is the low-fidelity model (eqs. 5-10). :class:`MixedFidelityODE`
keeps the half car's chassis (eqs. 5-6) and replaces each wheel equation (7-8) by a
multibody suspension module, with the force equations in their mixed-fidelity form
(eqs. 12-13). Both expose the same states, parameters and outputs, so one transcription
(:mod:`suspopt.problem`) serves both.

Node-wise inputs (Dymos targets): ``time``; states ``z_C, v_C, theta_C, omega_C`` and
``z_W1, v_W1, z_W2, v_W2`` (wheel travel); parameters ``k_S1, k_S2, c_S1, c_S2`` (design)
and ``M, I, a1, a2, k_T1, k_T2`` (+ ``m1, m2`` in the half car). Outputs: the state rates
``zdd_C, thdd_C, zdd_W1, zdd_W2``, the objective integrands ``dJ_dt`` and the forces.
"""
from __future__ import annotations

import openmdao.api as om

from suspopt.models.chassis import ChassisHeaveComp, ChassisPitchComp
from suspopt.models.forces import SuspensionForceComp, TyreForceComp
from suspopt.models.objective import ObjectiveIntegrandComp
from suspopt.models.wheel import WheelDynamicsComp
from suspopt.multibody.components import SuspensionDynamicsComp, SuspensionKinematicsComp
from suspopt.multibody.suspension import SuspensionModule
from suspopt.road import RoadInputComp, RoadProfile

CHASSIS_STATES = ('z_C', 'theta_C', 'v_C', 'omega_C')


class VehicleODE(om.Group):
    """Road, chassis and objective integrands shared by both fidelities; subclasses add the
    suspension-wheel part of each axle in :meth:`add_axle`."""

    #: signal that enters J3/J4 and the tyre force for axle i (state or multibody output)
    wheel_signal = 'z_W{i}'

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        self.options.declare('road', types=RoadProfile)
        self.options.declare('speed', types=float)
        self.options.declare('wheelbase', types=float, desc='L = a1 - a2 [m]')

    def setup(self) -> None:
        nn = self.options['num_nodes']
        self.add_subsystem('road', RoadInputComp(num_nodes=nn, road=self.options['road'],
                                                 speed=self.options['speed'],
                                                 offsets=(0.0, self.options['wheelbase'])),
                           promotes_inputs=['time'], promotes_outputs=['delta_1', 'delta_2'])
        for i in (1, 2):
            self.add_axle(i, nn)
        self.add_subsystem('chassis_heave', ChassisHeaveComp(num_nodes=nn),
                           promotes_inputs=['F_S1', 'F_S2', 'M'], promotes_outputs=['zdd_C'])
        self.add_subsystem('chassis_pitch', ChassisPitchComp(num_nodes=nn),
                           promotes_inputs=['F_S1', 'F_S2', 'a1', 'a2', 'I'],
                           promotes_outputs=['thdd_C'])
        w1, w2 = (self.wheel_signal.format(i=i) for i in (1, 2))
        self.add_subsystem('objective_integrand', ObjectiveIntegrandComp(num_nodes=nn),
                           promotes_inputs=['zdd_C', 'thdd_C', ('z_W1', w1), ('z_W2', w2)],
                           promotes_outputs=['dJ_dt'])

    def add_axle(self, i: int, nn: int) -> None:
        raise NotImplementedError

    def _add_forces(self, i: int, nn: int, spring_end: tuple[str, str], wheel: str) -> None:
        """Suspension (eq. 9/12) and tyre (eq. 10/13) forces of axle i."""
        self.add_subsystem(f'suspension_{i}', SuspensionForceComp(num_nodes=nn),
                           promotes_inputs=['z_C', 'v_C', 'theta_C', 'omega_C',
                                            ('z_W', spring_end[0]), ('v_W', spring_end[1]),
                                            ('k_S', f'k_S{i}'), ('c_S', f'c_S{i}'),
                                            ('a', f'a{i}')],
                           promotes_outputs=[('F_S', f'F_S{i}')])
        self.add_subsystem(f'tyre_{i}', TyreForceComp(num_nodes=nn),
                           promotes_inputs=[('delta', f'delta_{i}'), ('z_W', wheel),
                                            ('k_T', f'k_T{i}')],
                           promotes_outputs=[('F_T', f'F_T{i}')])


class HalfCarODE(VehicleODE):
    """Low-fidelity half car, paper eqs. 5-10 (SPEC §2)."""

    def add_axle(self, i: int, nn: int) -> None:
        self._add_forces(i, nn, spring_end=(f'z_W{i}', f'v_W{i}'), wheel=f'z_W{i}')
        self.add_subsystem(f'wheel_{i}', WheelDynamicsComp(num_nodes=nn),
                           promotes_inputs=[('F_S', f'F_S{i}'), ('F_T', f'F_T{i}'),
                                            ('m', f'm{i}')],
                           promotes_outputs=[('zdd_W', f'zdd_W{i}')])


class MixedFidelityODE(VehicleODE):
    """Mixed fidelity, paper §3.3: half-car chassis + one multibody module per axle.

    Per axle: kinematics (black box) → forces (eqs. 12-13, analytic) → dynamics (black
    box, eq. 11). The state ``z_W{i}`` is the module's wheel travel; ``q_W{i}`` (the
    wheel marker's vertical displacement) enters the tyre force and the objective.
    """

    wheel_signal = 'q_W{i}'

    def initialize(self) -> None:
        super().initialize()
        self.options.declare('modules', types=tuple,
                             desc='(front, rear) SuspensionModule instances')
        self.options.declare('fd_form', default='forward', values=('forward', 'central'))
        self.options.declare('fd_step', default=1e-6, types=float)

    def add_axle(self, i: int, nn: int) -> None:
        module: SuspensionModule = self.options['modules'][i - 1]
        fd = {'fd_form': self.options['fd_form'], 'fd_step': self.options['fd_step']}
        self.add_subsystem(f'kinematics_{i}', SuspensionKinematicsComp(num_nodes=nn,
                                                                        module=module, **fd),
                           promotes_inputs=[('z_W', f'z_W{i}'), ('v_W', f'v_W{i}')],
                           promotes_outputs=[(n, f'{n}{i}') for n in ('q_U', 'qd_U',
                                                                       'q_W', 'qd_W')])
        self._add_forces(i, nn, spring_end=(f'q_U{i}', f'qd_U{i}'), wheel=f'q_W{i}')
        self.add_subsystem(f'dynamics_{i}', SuspensionDynamicsComp(num_nodes=nn, module=module,
                                                                    **fd),
                           promotes_inputs=[('z_W', f'z_W{i}'), ('v_W', f'v_W{i}'),
                                            ('F_S', f'F_S{i}'), ('F_T', f'F_T{i}')],
                           promotes_outputs=[('zdd_W', f'zdd_W{i}'),
                                             ('reactions', f'reactions_{i}')])
