"""One scenario's Dymos phase: the vehicle ODE on a Radau grid (paper §3.4-3.5)."""

from __future__ import annotations

import dymos as dm
import numpy as np

from suspopt.models.design import DESIGN_UNITS, design_kind
from suspopt.models.vehicle import LowFidelityODE, MixedFidelityODE, VehicleSpec
from suspopt.road import road_tracks
from suspopt.spec.schema import Scenario, StudyConfig

FIDELITIES = ('low', 'mixed')


def state_defs(spec: VehicleSpec) -> list[tuple[str, str, str, float, tuple[int, ...]]]:
    """(state, rate source, units, ref, shape) of the transcription, paper eq. 2 and SPEC
    §5. ``ref`` is a typical magnitude over a road feature of a few centimetres; it scales
    the states and defects for IPOPT and changes no result."""
    nc = (spec.layout.n,)
    out = [
        ('z_C', 'v_C', 'm', 0.02, (1,)),
        ('v_C', 'zdd_C', 'm/s', 0.2, (1,)),
        ('theta_C', 'omega_C', 'rad', 0.01, (1,)),
        ('omega_C', 'thdd_C', 'rad/s', 0.2, (1,)),
    ]
    if spec.layout.has_roll:
        out += [('phi_C', 'p_C', 'rad', 0.01, (1,)), ('p_C', 'phidd_C', 'rad/s', 0.2, (1,))]
    out += [('z_W', 'v_W', 'm', 0.05, nc), ('v_W', 'zdd_W', 'm/s', 1.0, nc)]
    return out


def timeseries_names(spec: VehicleSpec, fidelity: str) -> tuple[str, ...]:
    """Signals recorded along the trajectory (beyond the states)."""
    chassis = ('zdd_C', 'thdd_C') + (('phidd_C',) if spec.layout.has_roll else ())
    forces = ('zdd_W', 'F_S', 'F_T', 'delta', 'z_M') + (('F_R',) if spec.bars[0] else ())
    mixed = ('q_W', 'reactions') if fidelity == 'mixed' else ()
    if fidelity == 'mixed' and spec.mount == 'chassis':
        mixed += ('F_M',)
    return chassis + forces + mixed


def vehicle_spec(
    config: StudyConfig, scenario: Scenario, fidelity: str, modules: dict[str, object] | None = None
) -> VehicleSpec:
    """The plain description of the vehicle ODE of ``config`` in ``scenario``; ``modules``
    maps a mechanism name to its (shared) multibody module for the mixed fidelity."""
    v = config.vehicle
    lay = v.layout()
    axles = v.axles
    bar_axles = tuple(i for i, ax in enumerate(axles) if ax.anti_roll_bar)
    pairs = lay.anti_roll_pairs(bar_axles)
    bars = (
        tuple(p[1] for p in pairs),
        tuple(p[2] for p in pairs),
        tuple(axles[p[0]].track for p in pairs),
    )
    tracks = road_tracks(scenario.road, lay.n_tracks, lay.track_separation())
    corner_modules = ()
    if fidelity == 'mixed':
        corner_modules = tuple(modules[axles[c.axle].mechanism] for c in lay.corners)
    return VehicleSpec(
        layout=lay,
        M=v.chassis_mass,
        I=v.chassis_pitch_inertia,
        I_x=v.chassis_roll_inertia,
        m=np.array([axles[c.axle].wheel_mass for c in lay.corners]),
        k_T=np.array([axles[c.axle].tyre_stiffness for c in lay.corners]),
        design=config.design_names(),
        bars=bars,
        tracks=tracks,
        speed=float(scenario.speed),
        modules=corner_modules,
        fd_form=config.multibody.fd_form,
        fd_step=config.multibody.fd_step,
        mount=config.multibody.mount,
    )


def build_phase(spec: VehicleSpec, fidelity: str, scenario: Scenario) -> dm.Phase:
    """A Dymos Radau phase of the vehicle ODE over the scenario's horizon, from the zero
    initial state (SPEC §1), with the design variables as its (static) parameters."""
    if fidelity not in FIDELITIES:
        raise ValueError(f'fidelity must be one of {FIDELITIES}, got {fidelity!r}')
    ode = LowFidelityODE if fidelity == 'low' else MixedFidelityODE
    phase = dm.Phase(
        ode_class=ode,
        ode_init_kwargs={'spec': spec},
        transcription=dm.Radau(
            num_segments=scenario.segments, order=scenario.order, compressed=True
        ),
    )
    # the ODE's spec (with the multibody modules) stays out of the recorder's metadata
    phase.recording_options['options_excludes'] = ['ode_init_kwargs']
    phase.set_time_options(
        fix_initial=True,
        fix_duration=True,
        units='s',
        targets=['time'],
        duration_val=scenario.horizon,
    )
    for name, rate, units, ref, shape in state_defs(spec):
        phase.add_state(
            name,
            rate_source=rate,
            units=units,
            fix_initial=True,
            targets=[name],
            ref=ref,
            shape=shape,
        )
    for name in spec.design:  # values from the trajectory's parameter of the same name
        phase.add_parameter(
            name,
            units=DESIGN_UNITS[design_kind(name)],
            opt=False,
            static_target=True,
            targets=[name],
        )
    for name in timeseries_names(spec, fidelity):
        phase.add_timeseries_output(name)
    return phase
