"""One scenario's Dymos phase: the vehicle ODE on a Radau grid (paper §3.4-3.5)."""

from __future__ import annotations

import dymos as dm

from suspopt.models.assembly import VehicleAssembly
from suspopt.models.design import DESIGN_UNITS, design_kind
from suspopt.models.vehicle import VehicleODE
from suspopt.spec.resolve import Scenario


def build_phase(
    assembly: VehicleAssembly,
    scenario: Scenario,
) -> dm.Phase:
    """A Dymos Radau phase of the vehicle's ODE over the scenario's horizon, from the zero
    initial state (``docs/model.md``), with the design variables as its (static)
    parameters, the assembly's open-loop controls as Dymos controls and its path bounds
    as path constraints (``docs/codesign.md``), and the assembly's signals recorded along
    the trajectory (the engineering constraints on it: :mod:`suspopt.transcription.
    constraints`)."""
    phase = dm.Phase(
        ode_class=VehicleODE,
        ode_init_kwargs={'assembly': assembly},
        transcription=dm.Radau(
            num_segments=scenario.segments, order=scenario.order, compressed=True
        ),
    )
    # the ODE's assembly (with the multibody modules) stays out of the recorder's metadata
    phase.recording_options['options_excludes'] = ['ode_init_kwargs']
    phase.set_time_options(
        fix_initial=True,
        fix_duration=True,
        units='s',
        targets=['time'],
        duration_val=scenario.horizon,
    )
    for state in assembly.states:
        phase.add_state(
            state.name,
            rate_source=state.rate,
            units=state.units,
            fix_initial=True,
            targets=[state.name],
            ref=state.ref,
            shape=state.shape,
        )
    for name in assembly.spec.design:  # values from the trajectory's parameter of that name
        phase.add_parameter(
            name,
            units=DESIGN_UNITS[design_kind(name)],
            opt=False,
            static_target=True,
            targets=[name],
        )
    for ctrl in assembly.controls:
        # a value at each LGR point of a segment, the control the degree-(order - 1)
        # polynomial through them: discontinuous at segment ends (docs/codesign.md)
        phase.add_control(
            ctrl.name,
            units=ctrl.units,
            shape=ctrl.shape,
            lower=ctrl.lower,
            upper=ctrl.upper,
            ref0=ctrl.ref0,
            ref=ctrl.ref,
            opt=True,
            continuity=False,
            rate_continuity=False,
            targets=[ctrl.name],
        )
    for bound in assembly.path_bounds:
        phase.add_path_constraint(bound.signal, lower=bound.lower, upper=bound.upper, ref=bound.ref)
    for name in assembly.timeseries:
        phase.add_timeseries_output(name)
    return phase
