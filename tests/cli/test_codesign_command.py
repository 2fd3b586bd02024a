"""``suspopt codesign``: the co-design study from the command line — the three laws of a
small active quarter car written to ``codesign.json`` as they come in, its table and
figure, ``report`` rendering the same table again, and bad input refused before any work."""

from __future__ import annotations

import json

from suspopt.cli.main import main

STUDY = """
[vehicle]
model = "quarter_car"

[maneuver]
speed = 10.0
horizon = 1.0

[road]
profile = "bump"
start = 2.0
length = 2.0
height = 0.04

[design]
k_S1 = {{ initial = 20000.0, lower = 5000.0, upper = 60000.0 }}
c_S1 = {{ initial = 1500.0, lower = 50.0, upper = 6000.0 }}

[transcription]
segments = 80
order = 3
{control}
[objective]
normalization = "custom"
weights = {{ heave = 0.5, tyre_load_1 = 0.5{effort} }}
scales = {{ heave = 1.0, tyre_load_1 = 1e6{effort_scale} }}
"""
CONTROL = """
[control]
kind = "active"
"""


def test_codesign_writes_every_law_its_table_and_figure_and_report_renders_it(tmp_path, capsys):
    study = tmp_path / 'study.toml'
    study.write_text(
        STUDY.format(control=CONTROL, effort=', control_1 = 0.1', effort_scale=', control_1 = 1e5')
    )
    out = tmp_path / 'out'
    code = main(['codesign', '--config', str(study), '--out', str(out), '--quiet'])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads((out / 'codesign.json').read_text())
    assert json.loads((out / 'manifest.json').read_text())['kind'] == 'codesign'
    assert list(data['entries']) == ['passive', 'open_loop', 'feedback']
    assert data['complete'] and data['control'] == 'active'
    f = data['objectives']
    # the open-loop control bounds every law; the feedback law is no worse than passive
    assert f['open_loop'] <= f['feedback'] <= f['passive'] * (1 + 1e-6)
    assert 0.0 <= data['feedback_recovers'] <= 1.0
    table = (out / 'table.md').read_text()
    assert table.count('| verified |') == 3 and 'realizes' in table
    assert (out / 'figures' / 'codesign.png').stat().st_size > 0
    assert (out / 'inputs').is_dir()  # the road as used
    (out / 'table.md').unlink()
    assert main(['report', str(out)]) == 0
    assert (out / 'table.md').read_text() == table


def test_a_study_without_control_is_refused_before_any_work(tmp_path, capsys):
    study = tmp_path / 'study.toml'
    study.write_text(STUDY.format(control='', effort='', effort_scale=''))
    out = tmp_path / 'out'
    assert main(['codesign', '--config', str(study), '--out', str(out)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert 'control.kind' in line and not out.exists()
