"""The vehicle of a study in one scenario: the plain description of its model
(:class:`~suspopt.models.assembly.VehicleSpec`) and its multibody modules, from the study
description."""

from __future__ import annotations

from typing import Any

import numpy as np

from suspopt.models.assembly import ControlSpec, VehicleAssembly, VehicleSpec, assemble
from suspopt.models.metrics import static_loads
from suspopt.multibody.suspension import SuspensionModule
from suspopt.road import road_tracks
from suspopt.spec.resolve import Scenario
from suspopt.spec.schema import StudyConfig


def multibody_modules(config: StudyConfig) -> dict[str, Any]:
    """One multibody module per distinct mechanism of the car (shared by its corners)."""
    names = dict.fromkeys(ax.mechanism for ax in config.vehicle.axles)
    return {n: SuspensionModule(n, mount=config.multibody.mount) for n in names}


def vehicle_spec(
    config: StudyConfig, scenario: Scenario, fidelity: str, modules: dict[str, Any] | None = None
) -> VehicleSpec:
    """The plain description of the vehicle model of ``config`` in ``scenario``;
    ``modules`` maps a mechanism name to its (shared) multibody module for the mixed
    fidelity (:func:`multibody_modules`)."""
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
    wheel_mass = np.array([axles[c.axle].wheel_mass for c in lay.corners])
    static = static_loads(lay, v.chassis_mass, wheel_mass)
    corner_modules: tuple = ()
    if fidelity == 'mixed':
        modules = modules or multibody_modules(config)
        corner_modules = tuple(modules[axles[c.axle].mechanism] for c in lay.corners)
    return VehicleSpec(
        layout=lay,
        M=v.chassis_mass,
        I=v.chassis_pitch_inertia,
        I_x=v.chassis_roll_inertia,
        m=wheel_mass,
        k_T=np.array([axles[c.axle].tyre_stiffness for c in lay.corners]),
        design=config.design_names(),
        bars=bars,
        tracks=road_tracks(scenario.road, lay.n_tracks, lay.track_separation()),
        speed=float(scenario.speed),
        modules=corner_modules,
        fd_form=config.multibody.fd_form,
        fd_step=config.multibody.fd_step,
        mount=config.multibody.mount,
        static_load=static,
        seats=tuple((s.name, s.x, s.y) for s in config.comfort.seats),
        control=control_spec(config, static),
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
