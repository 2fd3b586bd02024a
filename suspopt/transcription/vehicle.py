"""The vehicle of a study in one scenario: the plain description of its model
(:class:`~suspopt.models.assembly.VehicleSpec`) and its multibody modules, from the study
description."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from suspopt.curves import SpringDamperUnit
from suspopt.errors import ConfigError
from suspopt.models.assembly import ControlSpec, VehicleAssembly, VehicleSpec, assemble
from suspopt.multibody.mechanism import Mechanism, load_mechanism
from suspopt.multibody.suspension import SuspensionModule
from suspopt.spec.hardware import AXLE_KEYS, corner_units, study_units
from suspopt.spec.modes import passive_vehicle_spec
from suspopt.spec.resolve import Scenario
from suspopt.spec.schema import StudyConfig


def module_keys(config: StudyConfig) -> tuple[str, ...]:
    """The key of each axle's multibody module (:func:`multibody_modules`): its mechanism's
    name, and the axle where the study gives it curves (``docs/nonlinear_hardware.md``;
    axles with the same mechanism and the same curves share one)."""
    axles = config.vehicle.axles
    units = study_units(config)
    keys: list[str] = []
    for a, ax in enumerate(axles):
        unit = units[a] if a < len(units) else None
        same = [
            keys[b]
            for b in range(a)
            if axles[b].mechanism == ax.mechanism and (units[b] if b < len(units) else None) == unit
        ]
        keys.append(
            same[0]
            if same
            else ax.mechanism
            if unit is None
            else f'{ax.mechanism} ({AXLE_KEYS[a]})'
        )
    return tuple(keys)


def with_hardware(mechanism: Mechanism, unit: SpringDamperUnit) -> Mechanism:
    """The suspension mechanism with the study's curves on its suspension spring (they
    replace the file's stiffness, damping and curves)."""
    spring = mechanism.roles['spring']
    element: Any = mechanism.force(spring)
    if not hasattr(element, 'curves'):
        raise ConfigError(
            f'{mechanism.name}: its suspension spring {spring!r} ({element.type}) takes no '
            'curves: a spring_damper or linear_spring_damper is needed'
        )
    forces = tuple(
        dataclasses.replace(f, curves=unit, stiffness=0.0, damping=0.0) if f is element else f
        for f in mechanism.forces
    )
    return dataclasses.replace(mechanism, forces=forces)


def multibody_modules(config: StudyConfig) -> dict[str, Any]:
    """One multibody module per distinct mechanism of the car (shared by its corners), and
    per axle with the study's curves on its spring (:func:`module_keys`)."""
    units = study_units(config)
    out: dict[str, Any] = {}
    for a, (key, ax) in enumerate(zip(module_keys(config), config.vehicle.axles)):
        if key in out:
            continue
        unit = units[a] if a < len(units) else None
        mechanism: Any = ax.mechanism
        if unit is not None:
            mechanism = with_hardware(load_mechanism(ax.mechanism, suspension=True), unit)
        out[key] = SuspensionModule(mechanism, mount=config.multibody.mount)
    return out


def vehicle_spec(
    config: StudyConfig, scenario: Scenario, fidelity: str, modules: dict[str, Any] | None = None
) -> VehicleSpec:
    """The plain description of the vehicle model of ``config`` in ``scenario``;
    ``modules`` maps a mechanism name to its (shared) multibody module for the mixed
    fidelity (:func:`multibody_modules`)."""
    base = passive_vehicle_spec(config, scenario)
    assert base.static_load is not None  # the passive spec states its static loads
    corner_modules: tuple = ()
    if fidelity == 'mixed':
        modules = modules or multibody_modules(config)
        keys = module_keys(config)
        corner_modules = tuple(modules[keys[c.axle]] for c in base.layout.corners)
    return dataclasses.replace(
        base,
        modules=corner_modules,
        fd_form=config.multibody.fd_form,
        fd_step=config.multibody.fd_step,
        mount=config.multibody.mount,
        seats=tuple((s.name, s.x, s.y) for s in config.comfort.seats),
        units=corner_units(config) if any(study_units(config)) else (),
        control=control_spec(config, base.static_load),
    )


def control_spec(config: StudyConfig, static_load: np.ndarray) -> ControlSpec | None:
    """The controlled suspension of ``config`` (None: passive), its force scale resolved:
    ``force_scale``, else ``force_max``, else a tenth of the controlled corners' mean
    static load (``docs/codesign.md``)."""
    c = config.control
    if not c.enabled:
        return None
    labels = config.layout().labels
    corners = tuple(labels.index(x) for x in config.controlled())
    scale = c.force_scale or c.force_max or 0.1 * float(np.mean(static_load[list(corners)]))
    return ControlSpec(
        kind=c.kind,
        law=c.law,
        corners=corners,
        force_max=c.force_max,
        power_max=c.power_max,
        c_min=c.c_min,
        c_max=c.c_max,
        force_scale=scale,
        smoothing=c.smoothing,
        velocity_floor=c.velocity_floor,
    )


def vehicle_assembly(
    config: StudyConfig, scenario: Scenario, fidelity: str, modules: dict[str, Any] | None = None
) -> VehicleAssembly:
    """The vehicle model of ``config`` in ``scenario``
    (:func:`suspopt.models.assembly.assemble`)."""
    return assemble(vehicle_spec(config, scenario, fidelity, modules), fidelity)
