"""Resolving a study description once: its scenarios, each with its grid (the automatic
grid rule below), and the checks that a grid can represent the motion.

``transcription.segments = "auto"`` picks the number of uniform segments of a scenario
from its horizon, the model's fastest mode and the road's content:

    f = max(f_hop, min(v n_road, 2 f_hop)),     segments = ceil(T f P / order),

with ``f_hop = max_c sqrt((k_S,max + k_T + k_R,max / t²) / m) / 2π`` the stiffest
wheel-hop frequency over the design box (the fastest mode of the half and full car),
``n_road`` the road's highest significant spatial frequency
(:meth:`~suspopt.road.RoadProfile.max_frequency`) and ``P = 12.5`` collocation nodes per
period of ``f``. Road content above twice the wheel-hop frequency reaches the objective
only through the tyre's filtering and is not resolved, except a road's discrete features
(bumps, steps: :attr:`~suspopt.road.RoadProfile.transient`), which the nodes must
sample: a bump between two nodes is not seen at all. Every result checks its grid
against time marching (``benchmarks/grid_convergence.py`` measures the rule).

A grid given as a number is checked before any work (:func:`grid_problems`): fewer than
:data:`MIN_NODES_PER_PERIOD` collocation nodes per period of the wheel hop or of the
road's discrete features cannot represent the motion, and the study is refused with the
cause; ``"auto"`` meets that floor by construction.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from suspopt.curves import SpringTable
from suspopt.models.design import design_id
from suspopt.road import road_tracks

if TYPE_CHECKING:  # the schema builds on this module; only its types are used here
    from suspopt.spec.schema import StudyConfig


@dataclass(frozen=True)
class Scenario:
    """A resolved load case (every value set)."""

    name: str
    weight: float
    speed: float
    horizon: float
    road: dict[str, Any]
    segments: int
    order: int

    @property
    def length(self) -> float:
        """Distance driven [m]."""
        return self.speed * self.horizon


#: collocation nodes per period of the fastest resolved frequency (see the module doc)
NODES_PER_PERIOD = 12.5
#: road content above this multiple of the wheel-hop frequency is not resolved
ROAD_FREQUENCY_CAP = 2.0
#: fewer collocation nodes than this per period of a resolved frequency: the grid is refused
MIN_NODES_PER_PERIOD = 2.0


def wheel_hop_frequency(config: StudyConfig) -> float:
    """The stiffest wheel-hop frequency over the design box [Hz] (the fastest mode)."""
    v, design = config.vehicle, config.design
    layout = v.layout()
    f = 0.0
    for c in layout.corners:
        axle = v.axles[c.axle]
        ks = [
            design[n].upper
            for n in design.names
            if design_id(n).kind.symbol == 'k_S' and design_id(n).axle == c.axle
        ]
        kr = [design[n].upper for n in design.names if n == f'k_R{c.axle + 1}']
        k = (max(ks) if ks else _table_rate(axle.spring_curve)) + axle.tyre_stiffness
        if kr and axle.track > 0.0:
            k += kr[0] / axle.track**2
        f = max(f, math.sqrt(k / axle.wheel_mass) / (2.0 * math.pi))
    return f


def _table_rate(table: dict[str, Any]) -> float:
    """A spring table's rate at static [N/m] (an axle whose spring is a table has no
    ``k_S``, ``docs/nonlinear_hardware.md``); 0 if it does not read (its checks say why)."""
    try:
        curve = SpringTable(tuple(table['deflections']), tuple(table['forces']))
        return max(float(curve.derivative(0.0)), 0.0)
    except (KeyError, TypeError, ValueError, IndexError):
        return 0.0


def resolved_frequencies(config: StudyConfig, scenario: Scenario) -> list[tuple[float, str]]:
    """The frequencies [Hz] a grid of ``scenario`` must resolve, each with what it is: the
    stiffest wheel hop, the road content up to :data:`ROAD_FREQUENCY_CAP` times it, and
    the road's discrete features (bumps, steps) whatever their frequency."""

    f_hop = wheel_hop_frequency(config)
    layout = config.layout()
    tracks = road_tracks(scenario.road, layout.n_tracks, layout.track_separation())
    out = [(f_hop, 'the wheel hop (stiffest over the design box)')]
    for road in tracks:
        f = scenario.speed * road.max_frequency()
        if road.transient:
            out.append((f, f"the road's {road.kind} ({road.feature()} at {scenario.speed:g} m/s)"))
        else:
            out.append(
                (
                    min(f, ROAD_FREQUENCY_CAP * f_hop),
                    f'the road content ({road.kind} up to {f:.3g} Hz at '
                    f'{scenario.speed:g} m/s, resolved up to '
                    f'{ROAD_FREQUENCY_CAP:g} x the wheel hop)',
                )
            )
    return out


def auto_segments(config: StudyConfig, scenario: Scenario, order: int) -> int:
    """The automatic number of segments of ``scenario`` (see the module docstring)."""
    freqs = resolved_frequencies(config, scenario)
    f_hop = freqs[0][0]
    f = max(f_hop, min(max(f for f, _ in freqs[1:]), ROAD_FREQUENCY_CAP * f_hop))
    n = math.ceil(scenario.horizon * f * NODES_PER_PERIOD / order)
    floor = math.ceil(scenario.horizon * max(f for f, _ in freqs) * MIN_NODES_PER_PERIOD / order)
    return max(2, n, floor)


def grid_problems(config: StudyConfig, scenario: Scenario, key: str) -> list[str]:
    """Why the grid of ``scenario`` cannot represent its motion (empty if it can): fewer
    than :data:`MIN_NODES_PER_PERIOD` collocation nodes per period of the wheel hop or of
    the road's discrete features (:func:`resolved_frequencies`); a random road's content
    above the wheel hop is left to the time-marching verification (the tyre filters it).
    ``key`` names the grid's key in the study file."""
    nodes_per_s = scenario.segments * scenario.order / scenario.horizon
    freqs = resolved_frequencies(config, scenario)

    layout = config.layout()
    tracks = road_tracks(scenario.road, layout.n_tracks, layout.track_separation())
    must = [freqs[0]] + [fw for fw, road in zip(freqs[1:], tracks) if road.transient]
    for f, what in must:
        if f > 0.0 and nodes_per_s / f < MIN_NODES_PER_PERIOD:
            need = math.ceil(scenario.horizon * f * MIN_NODES_PER_PERIOD / scenario.order)
            auto = auto_segments(config, scenario, scenario.order)
            return [
                f'{key}: {scenario.segments} segment(s) of order {scenario.order} over '
                f'{scenario.horizon:g} s give {nodes_per_s / f:.2g} collocation nodes per '
                f'period of {what}, {f:.3g} Hz: too coarse to represent the motion (at '
                f'least {MIN_NODES_PER_PERIOD:g} nodes per period, {need} segments; '
                f'"auto" gives {auto})'
            ]
    return []


def resolve_segments(config: StudyConfig, scenario: Scenario, segments: Any) -> int:
    """The number of segments of a scenario: as given, or :func:`auto_segments`."""
    if segments == 'auto':
        return auto_segments(config, scenario, scenario.order)
    return int(segments)


def nlp_size(config: StudyConfig, scenario: Scenario) -> int:
    """Number of NLP variables of one scenario (its discretized states), before building it."""
    layout = config.layout()
    n_states = 2 * (len(layout.dofs) + layout.n) + 8 * len(config.comfort.seats)
    return (scenario.segments * scenario.order + 1) * n_states


def scenarios(config: StudyConfig) -> tuple[Scenario, ...]:
    """The load cases of ``config``, every value resolved (the top-level tables fill the
    gaps, ``"auto"`` grids computed); :meth:`StudyConfig.scenarios` keeps the answer."""
    base = Scenario(
        name='main',
        weight=1.0,
        speed=config.maneuver.speed,
        horizon=config.maneuver.horizon,
        road=dict(config.road),
        segments=0,
        order=config.transcription.order,
    )
    if not config.scenario:
        return (_with_grid(config, base, config.transcription.segments),)
    out = []
    names = scenario_names(config)
    for i, sc in enumerate(config.scenario):
        s = Scenario(
            name=names[i],
            weight=sc.weight,
            speed=sc.speed or base.speed,
            horizon=sc.horizon or base.horizon,
            road=dict(sc.road) if sc.road else base.road,
            segments=0,
            order=sc.order or base.order,
        )
        out.append(_with_grid(config, s, sc.segments or config.transcription.segments))
    return tuple(out)


def scenario_names(config: StudyConfig) -> list[str]:
    """Every scenario's name: its own, or ``s<i>`` for one without (``s<i>_2`` ... where a
    given name took it): unique by construction, so a table row or a figure's curve never
    shows another scenario's data under its label."""
    return unique_names([sc.name for sc in config.scenario])


def unique_names(given: list[str]) -> list[str]:
    """Names for scenarios whose given names are ``given`` ('' for none): see
    :func:`scenario_names`."""
    taken = {n for n in given if n}
    out: list[str] = []
    for i, name in enumerate(given):
        k = 2
        if not name:
            name = f's{i}'
            while name in taken or name in out:
                name, k = f's{i}_{k}', k + 1
        out.append(name)
    return out


def _with_grid(config: StudyConfig, scenario: Scenario, segments: Any) -> Scenario:
    return dataclasses.replace(scenario, segments=resolve_segments(config, scenario, segments))
