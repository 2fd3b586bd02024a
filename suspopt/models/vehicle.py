"""The vehicle models as ODE groups for Dymos (paper §3.1 and §3.3), over corners.

:class:`LowFidelityODE` is the half car (eqs. 5-10) or the full car (heave, pitch, roll,
four wheels, optional anti-roll bars). :class:`MixedFidelityODE` keeps its chassis and
replaces each wheel equation (7-8) by a multibody suspension module, with the force
equations in their mixed-fidelity form (eqs. 12-13). Both expose the same states,
parameters and outputs, so one transcription (:mod:`suspopt.transcription`) serves both.

Node-wise inputs (Dymos targets): ``time``; chassis states ``z_C, v_C, theta_C, omega_C``
(and ``phi_C, p_C`` for the full car), each (nodes,); wheel travel ``z_W, v_W``, each
(nodes, corners); the design variables (static). Outputs: the state rates ``zdd_C,
thdd_C`` (``phidd_C``) and ``zdd_W``, the objective integrands ``dJ_dt`` and the forces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import openmdao.api as om

from suspopt.models.chassis import ChassisHeaveComp, ChassisPitchComp, ChassisRollComp
from suspopt.models.forces import (
    AntiRollBarComp,
    MountMotionComp,
    SuspensionForceComp,
    TyreForceComp,
    WheelLoadComp,
)
from suspopt.models.layout import VehicleLayout
from suspopt.models.mount import ChassisMountComp, MountResponseComp, MountRotationComp
from suspopt.models.objective import ObjectiveIntegrandComp
from suspopt.models.road_input import RoadInputComp
from suspopt.models.settings import SuspensionSettingsComp
from suspopt.models.wheel import WheelDynamicsComp


@dataclass(frozen=True)
class VehicleSpec:
    """Everything an ODE of one vehicle in one scenario needs (plain values; built by the
    transcription from the study description)."""

    layout: VehicleLayout
    M: float
    I: float
    I_x: float
    m: np.ndarray
    k_T: np.ndarray
    design: tuple[str, ...]
    bars: tuple[tuple[int, ...], tuple[int, ...], tuple[float, ...]]
    tracks: tuple
    speed: float
    modules: tuple = ()
    fd_form: str = 'forward'
    fd_step: float = 1e-6
    mount: str = 'ground'

    @property
    def chassis_states(self) -> tuple[str, ...]:
        out = ('z_C', 'v_C', 'theta_C', 'omega_C')
        return out + (('phi_C', 'p_C') if self.layout.has_roll else ())


class VehicleODE(om.Group):
    """Road, settings, chassis and objective integrands shared by both fidelities;
    subclasses add the suspension-wheel part in :meth:`add_wheels`."""

    #: the signal that enters the tyre force and the wheel terms (state or multibody output)
    wheel_signal = 'z_W'

    def initialize(self) -> None:
        self.options.declare('num_nodes', types=int)
        # not in the case recorder's metadata: it holds the multibody modules (their kept
        # poses and tables), megabytes per system and per setup, which nothing reads back
        self.options.declare('spec', types=VehicleSpec, recordable=False)

    def setup(self) -> None:
        nn, spec = self.options['num_nodes'], self.options['spec']
        lay = spec.layout
        nc, roll = lay.n, lay.has_roll
        kw = {'num_nodes': nn, 'corners': nc}
        self.add_subsystem(
            'road',
            RoadInputComp(
                num_nodes=nn,
                tracks=spec.tracks,
                speed=spec.speed,
                offsets=lay.offsets(),
                track_of=tuple(c.track for c in lay.corners),
            ),
            promotes_inputs=['time'],
            promotes_outputs=['delta'],
        )
        self.add_subsystem(
            'settings',
            SuspensionSettingsComp(design=spec.design, labels=lay.labels),
            promotes=['*'],
        )
        self.add_subsystem(
            'mount', MountMotionComp(a=lay.a, y=lay.y, roll=roll, **kw), promotes=['*']
        )
        forces = self.add_wheels(nn, spec)
        self.add_chassis(nn, spec, forces)
        ins = ['zdd_C', 'thdd_C'] + (['phidd_C'] if roll else []) + [('wheel_z', self.wheel_signal)]
        self.add_subsystem(
            'objective_integrand',
            ObjectiveIntegrandComp(roll=roll, **kw),
            promotes_inputs=ins,
            promotes_outputs=['dJ_dt'],
        )

    def add_chassis(self, nn: int, spec: VehicleSpec, forces: tuple[str, ...]) -> None:
        """Add the chassis equations (eqs. 5-6, roll) driven by the ``forces`` per corner."""
        lay = spec.layout
        kw = {'num_nodes': nn, 'corners': lay.n}
        chassis = [
            ('chassis_heave', ChassisHeaveComp(M=spec.M, forces=forces, **kw), 'zdd_C'),
            ('chassis_pitch', ChassisPitchComp(a=lay.a, I=spec.I, forces=forces, **kw), 'thdd_C'),
        ]
        if lay.has_roll:
            chassis.append(
                (
                    'chassis_roll',
                    ChassisRollComp(y=lay.y, I_x=spec.I_x, forces=forces, **kw),
                    'phidd_C',
                )
            )
        for name, comp, out in chassis:
            self.add_subsystem(name, comp, promotes_inputs=list(forces), promotes_outputs=[out])

    def add_wheels(self, nn: int, spec: VehicleSpec) -> tuple[str, ...]:
        """Add the suspension and wheels; return the names of the forces on the chassis."""
        raise NotImplementedError

    def _add_anti_roll(self, nn: int, spec: VehicleSpec, wheel: str) -> bool:
        left, right, track = spec.bars
        if not left:
            return False
        self.add_subsystem(
            'anti_roll',
            AntiRollBarComp(
                num_nodes=nn, corners=spec.layout.n, left=left, right=right, track=track
            ),
            promotes_inputs=[('z_W', wheel), 'z_M', 'k_R'],
            promotes_outputs=['F_R'],
        )
        return True


class LowFidelityODE(VehicleODE):
    """The low-fidelity vehicle: half car, paper eqs. 5-10 (SPEC §2), or full car."""

    def add_wheels(self, nn: int, spec: VehicleSpec) -> tuple[str, ...]:
        kw = {'num_nodes': nn, 'corners': spec.layout.n}
        self.add_subsystem('suspension', SuspensionForceComp(**kw), promotes=['*'])
        forces = ('F_S', 'F_R') if self._add_anti_roll(nn, spec, 'z_W') else ('F_S',)
        self.add_subsystem('tyre', TyreForceComp(k_T=spec.k_T, **kw), promotes=['*'])
        self.add_subsystem(
            'wheel', WheelDynamicsComp(m=spec.m, forces=forces, **kw), promotes=['*']
        )
        return forces


class MixedFidelityODE(VehicleODE):
    """Mixed fidelity, paper §3.3: the chassis + one multibody module at every corner.

    With ``spec.mount == 'chassis'`` the modules' frames move with the chassis: the
    modules take the mount's pose, return their response at zero and per unit mount
    acceleration, and :class:`~suspopt.models.mount.ChassisMountComp` solves the chassis
    equations with the linkage's reactions (the loop closed per node), then
    :class:`~suspopt.models.mount.MountResponseComp` gives ``zdd_W``, the vertical force
    on the chassis ``F_M`` and the reactions at the solved accelerations.

    Kinematics (black box) → tyre force (eq. 13, analytic) → dynamics (black box, eq. 11,
    with the suspension spring-damper inside the mechanism: its rate and damping and the
    chassis mount's motion are inputs, its vertical force on the chassis ``F_S`` of eq. 12
    an output). The state ``z_W`` is each module's wheel travel; ``q_W`` (the wheel
    marker's vertical displacement) enters the tyre force and the objective.
    """

    wheel_signal = 'q_W'

    def add_wheels(self, nn: int, spec: VehicleSpec) -> tuple[str, ...]:
        from suspopt.multibody.components import (
            ChassisMountDynamicsComp,
            SuspensionDynamicsComp,
            SuspensionKinematicsComp,
        )

        lay = spec.layout
        kw = {'num_nodes': nn, 'corners': lay.n}
        fd = {'modules': spec.modules, 'fd_form': spec.fd_form, 'fd_step': spec.fd_step}
        chassis = spec.mount == 'chassis'
        pose = []
        if chassis:
            pose = ['z_M', 'v_M']
            if lay.has_roll:
                self.add_subsystem(
                    'mount_rotation',
                    MountRotationComp(side=np.array([c.side for c in lay.corners]), **kw),
                    promotes=['*'],
                )
                pose += ['psi_M', 'w_M']
        self.add_subsystem(
            'kinematics',
            SuspensionKinematicsComp(**kw, **fd, mount=spec.mount, roll=lay.has_roll),
            promotes_inputs=['z_W', 'v_W', *pose],
            promotes_outputs=['q_W', 'qd_W'],
        )
        bars = self._add_anti_roll(nn, spec, 'q_W')
        self.add_subsystem(
            'tyre',
            TyreForceComp(k_T=spec.k_T, **kw),
            promotes_inputs=['delta', ('z_W', 'q_W')],
            promotes_outputs=['F_T'],
        )
        wheel_load = 'F_T'
        if bars:
            self.add_subsystem('wheel_load', WheelLoadComp(**kw), promotes=['*'])
            wheel_load = 'F_W'
        if chassis:
            self.add_subsystem(
                'dynamics',
                ChassisMountDynamicsComp(**kw, **fd, roll=lay.has_roll),
                promotes_inputs=['z_W', 'v_W', *pose, ('F_T', wheel_load), 'k_S', 'c_S'],
                promotes_outputs=['response', 'F_S'],
            )
            self._width = self.dynamics.width
            return ('F_R',) if bars else ()
        self.add_subsystem(
            'dynamics',
            SuspensionDynamicsComp(**kw, **fd),
            promotes_inputs=['z_W', 'v_W', 'z_M', 'v_M', ('F_T', wheel_load), 'k_S', 'c_S'],
            promotes_outputs=['zdd_W', 'F_S', 'reactions'],
        )
        return ('F_S', 'F_R') if bars else ('F_S',)

    def add_chassis(self, nn: int, spec: VehicleSpec, forces: tuple[str, ...]) -> None:
        if spec.mount != 'chassis':
            return super().add_chassis(nn, spec, forces)
        lay = spec.layout
        roll = lay.has_roll
        kw = {
            'num_nodes': nn,
            'corners': lay.n,
            'a': lay.a,
            'y': lay.y,
            'roll': roll,
            'side': np.array([c.side for c in lay.corners], dtype=float),
            'width': self._width,
        }
        acc = ['zdd_C', 'thdd_C'] + (['phidd_C'] if roll else [])
        self.add_subsystem(
            'chassis',
            ChassisMountComp(M=spec.M, I=spec.I, I_x=spec.I_x, forces=forces, **kw),
            promotes_inputs=['response', *forces],
            promotes_outputs=acc,
        )
        self.add_subsystem(
            'mount_response',
            MountResponseComp(**kw),
            promotes_inputs=['response', *acc],
            promotes_outputs=['zdd_W', 'F_M', 'reactions'],
        )
