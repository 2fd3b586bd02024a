"""The design-variable table (suspopt.models.design): identities as data, one spelling
of each unit per use, and the corners each variable acts on."""

from __future__ import annotations

import pytest

from suspopt.models.design import KINDS, corner_of_design, design_heading, design_id
from suspopt.models.layout import full_car, half_car
from suspopt.spec.load import config_from_dict, full_car_defaults


@pytest.mark.parametrize(
    'name, kind, axle, side',
    [('k_S1', 'k_S', 0, 0), ('c_S2', 'c_S', 1, 0), ('k_S2R', 'k_S', 1, -1), ('k_R1', 'k_R', 0, 0)],
)
def test_a_name_is_read_once_into_its_identity(name, kind, axle, side):
    d = design_id(name)
    assert (d.kind.symbol, d.axle, d.side) == (kind, axle, side) and d.name == name
    for bad in ('k_S3', 'x_S1', 'k_S1X', 'k_S'):
        with pytest.raises(ValueError):
            design_id(bad)


def test_every_spelling_of_a_unit_is_the_same_unit():
    superscript = str.maketrans('⁰¹²³⁴⁵⁶⁷⁸⁹', '0123456789')
    for kind in KINDS.values():
        base, _, power = kind.units.partition('**')
        assert base.replace('*', '·') + power == kind.display.translate(superscript)
        assert kind.units.replace('**', '^').replace('*', ' ') == kind.plain
    assert KINDS['k_S3'].display == 'N/m³' and KINDS['bump_k2'].plain == 'N/m^2'
    assert design_heading('c_S1') == 'c_S1 [N·s/m]' and design_heading('k_R2') == 'k_R2 [N·m/rad]'


@pytest.mark.parametrize('model', ['half', 'full per axle', 'full per corner'])
def test_each_variable_acts_on_the_corners_of_its_axle_or_its_own(model):
    """Against the corners' own axle and side (the layout), not the names' letters."""
    if model == 'half':
        cfg, lay = config_from_dict({}), half_car(1.0, -1.0)
    else:
        d = full_car_defaults().to_dict()
        d['design'] = {'per_corner': model == 'full per corner'}
        cfg, lay = config_from_dict(d), full_car(1.0, -1.0, 1.5, 1.5)
    where = corner_of_design(cfg.design_names(), lay.labels)
    bars = [n for n in cfg.design_names() if design_id(n).kind.per_bar]
    for name, targets in where.items():
        d = design_id(name)
        if d.kind.per_bar:
            assert targets == [('k_R', bars.index(name))]
            continue
        expected = [
            i
            for i, c in enumerate(lay.corners)
            if c.axle == d.axle and (d.side == 0 or c.side == d.side)
        ]
        assert [i for _, i in targets] == expected and expected, name
    # every corner gets exactly one spring and one damper
    for setting in ('k_S', 'c_S'):
        hits = sorted(i for t in where.values() for s, i in t if s == setting)
        assert hits == list(range(lay.n)), setting
