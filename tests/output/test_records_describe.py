"""Records and tables describe what was computed (suspopt.output.format and the checks
behind it): every scenario's terms, scales and the aggregate's formula wherever a result
is printed; no weights that the worst case ignores; labels unique by construction; no
reference scale from a term that is numerically zero; a verification that measures a
term numerically zero against a floor, not against zero."""

from __future__ import annotations

import pytest

from suspopt.cli.commands import summary
from suspopt.errors import ConfigError
from suspopt.records.solve import ScenarioResult, SolveRecord
from suspopt.records.verification import Verification
from suspopt.spec.load import _merge, config_from_dict, full_car_defaults

TERMS = {'heave': 2.0, 'pitch': 1.5}
WEIGHTS = {'heave': 0.5, 'pitch': 0.5}


def _two_scenarios(aggregate: str = 'sum') -> SolveRecord:
    a = ScenarioResult('city', 1.0, {'heave': 2.5, 'pitch': 1.25}, 0.9, dict(TERMS))
    b = ScenarioResult(
        'motorway', 2.0, {'heave': 7.5, 'pitch': 3.75}, 0.4, {'heave': 3.0, 'pitch': 1.0}
    )
    return SolveRecord(
        fidelity='low',
        mode='optimize',
        method='collocation',
        start={'k_S1': 3e4},
        design={'k_S1': 3.1e4},
        success=True,
        status='Solve_Succeeded',
        objective=1.7,
        scenarios=(a, b),
        aggregate=aggregate,
        normalization='reference',
        weights=WEIGHTS,
        verification=Verification.skipped(),
    )


def test_a_summary_of_several_scenarios_shows_each_with_the_formula():
    """Found: the printed summary showed the first scenario's terms and scales only, with
    a one-scenario formula."""
    text = summary(_two_scenarios())
    assert 'f = 1 f_city + 2 f_motorway' in text
    for name, heave, scale in (('city', '2', '2.5'), ('motorway', '3', '7.5')):
        line = next(ln for ln in text.splitlines() if f'scenario {name}' in ln)
        assert f'J_heave = {heave}' in line
        assert any(f'heave = {scale}' in ln for ln in text.splitlines() if 'scales' in ln)
    from suspopt.output.solve_report import run_markdown

    table = run_markdown(_two_scenarios())
    assert '| city |' in table and '| motorway |' in table
    assert '- city (w = 1): s = (heave 2.5' in table and '- motorway (w = 2)' in table
    assert 'f = 1 f_city + 2 f_motorway' in table


def test_a_study_table_of_several_scenarios_has_a_row_per_scenario():
    from suspopt.output.study_report import table_markdown
    from suspopt.records.twostep import TwoStepStudy

    rec = _two_scenarios()
    study = TwoStepStudy(
        config={
            'scenario': [{'name': 'city', 'weight': 1.0}, {'name': '', 'weight': 2.0}],
            'objective': {'aggregate': 'sum'},
        },
        scales=tuple(s.scales for s in rec.scenarios),
        terms=('heave', 'pitch'),
        design_names=('k_S1',),
        normalization='reference',
        weights=WEIGHTS,
        evaluations={'low/initial': rec},
        designs={'initial': rec.start},
    )
    table = table_markdown(study)
    assert 'f = 1 f_city + 2 f_s1' in table and '- s1 (w = 2): s = (heave 7.5' in table
    assert '| Initial guess | low | city | 2 |' in table
    assert '| Initial guess | low | motorway | 3 |' in table


def test_the_worst_case_refuses_scenario_weights():
    """Found: aggregate = "max" ignored the weights while the table printed them."""
    data = {
        'objective': {'aggregate': 'max'},
        'scenario': [{'name': 'a', 'weight': 3.0}, {'name': 'b'}],
    }
    with pytest.raises(ConfigError) as err:
        config_from_dict(data)
    (line,) = err.value.problems
    assert (
        line.startswith('scenario[0].weight: 3: the worst case') and 'no scenario weights' in line
    )
    data['scenario'][0]['weight'] = 1.0
    assert config_from_dict(data).objective.aggregate == 'max'
    from suspopt.output.robust_report import robust_markdown
    from suspopt.records.robust import RobustStudy

    table = robust_markdown(
        RobustStudy(
            config={'objective': {'normalization': 'paper', 'weights': WEIGHTS}},
            fidelity='low',
            scenarios=('a', 'b'),
            weights=(1.0, 1.0),
            aggregate='max',
            scales=({'heave': 1.0, 'pitch': 1.0},) * 2,
            design_names=('k_S1',),
        )
    )
    assert '(w = ' not in table and 'max(f_a, f_b)' in table


def test_scenario_and_mechanism_labels_are_unique_by_construction():
    """Found: a derived label could equal a given one (rows and curves showing another's
    data): two unnamed scenarios were refused as duplicates of '', an unnamed second
    scenario took the given name 's1'; two mechanism files of one stem shared a label."""
    cfg = config_from_dict({'scenario': [{}, {}]})
    assert [s.name for s in cfg.scenarios()] == ['s0', 's1']
    cfg = config_from_dict({'scenario': [{'name': 's1'}, {}]})
    assert [s.name for s in cfg.scenarios()] == ['s1', 's1_2']
    from suspopt.studies.compare import mechanism_labels, topology_labels

    labels = mechanism_labels(['/a/strut.toml', '/b/strut.toml', 'macpherson'])
    assert list(labels.values()) == ['strut', 'strut-2', 'macpherson']
    topologies = [('/a/strut.toml',) * 2, ('/b/strut.toml',) * 2]
    assert len(set(topology_labels(topologies))) == 2


def test_studies_refuse_labels_they_cannot_keep_apart(tmp_path):
    from suspopt.studies.pareto import run_pareto
    from suspopt.studies.robust import run_robust

    two = config_from_dict({'scenario': [{'name': 'a'}, {'name': 'b'}]})
    with pytest.raises(ConfigError, match='a Pareto front is traced on one load case'):
        run_pareto(two, tmp_path)
    named = config_from_dict({'scenario': [{'name': 'robust'}, {'name': 'b'}]})
    with pytest.raises(ConfigError, match="scenario\\[0\\].name: 'robust' names the robust"):
        run_robust(named, tmp_path)


#: the paper's objective on the full car (its default objective is comfort and road holding)
PAPER_WEIGHTS = {'heave': 1 / 6, 'pitch': 1 / 6, 'roll': 1 / 6, 'wheel': 0.5}


def test_a_reference_scale_of_a_term_the_road_does_not_excite_is_refused():
    """Found: roll on two tracks that differ only by a rounding of one height was
    accepted as a reference scale and weighted like a real term."""
    from suspopt.verification.scales import resolve_scales

    road = {
        'profile': 'two_tracks',
        'left': {'profile': 'bump', 'height': 0.02, 'length': 1.0, 'start': 0.5},
        'right': {'profile': 'bump', 'height': 0.0200000001, 'length': 1.0, 'start': 0.5},
    }
    data = _merge(full_car_defaults().to_dict(), {'maneuver': {'horizon': 0.4}})
    data['road'] = road
    data['objective'] = {'weights': PAPER_WEIGHTS}  # roll weighted
    with pytest.raises(ConfigError) as err:
        resolve_scales(config_from_dict(data))
    (line,) = err.value.problems
    # zero by the exact march, or numerically zero by an integrator: refused either way
    assert (line.startswith('objective.weights.roll: ') and 'numerically zero' in line) or (
        'does not excite roll' in line
    ), line
    data['road']['right']['height'] = 0.015  # a real difference: a real roll term
    assert resolve_scales(config_from_dict(data))[0]['roll'] > 0.0


def test_a_term_numerically_zero_verifies_against_a_floor():
    """Found: a term exactly 0 by time marching and 1e-30 by collocation differed by
    "inf %" and the result was NOT verified (exit 3)."""
    from suspopt.verification.verify import VERIFY_TOLERANCE, march, time_marching_check

    data = _merge(
        full_car_defaults().to_dict(),
        {
            'road': {'profile': 'bump', 'height': 0.02, 'length': 1.0, 'start': 0.5},
            'maneuver': {'horizon': 0.4},
        },
    )
    weighted = ['heave', 'pitch', 'roll', 'wheel_1L', 'wheel_1R', 'wheel_2L', 'wheel_2R']
    data['objective'] = {
        'weights': PAPER_WEIGHTS,
        'normalization': 'custom',
        'scales': dict.fromkeys(weighted, 1.0),
    }
    cfg = config_from_dict(data)
    scales = ({t: 1.0 for t in cfg.terms()},)
    marched = march(cfg, 'low', cfg.design.initial(), scales)[0].terms
    assert marched['roll'] == 0.0 and cfg.objective.weights['roll'] > 0.0
    terms = [{**marched, 'roll': 1e-30}]
    comparison, _ = time_marching_check(cfg, 'low', cfg.design.initial(), terms, scales)
    assert comparison.max_rel_diff < VERIFY_TOLERANCE, comparison
    terms = [{**marched, 'heave': marched['heave'] * 1.01}]  # a real term still counts
    comparison, _ = time_marching_check(cfg, 'low', cfg.design.initial(), terms, scales)
    assert comparison.max_rel_diff == pytest.approx(0.01, rel=1e-3)
