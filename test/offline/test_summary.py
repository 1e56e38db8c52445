"""The typed summary of an analysis (gear_phm.offline.summary): attributes, JSON, reading."""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest
import yaml

from gear_phm.cli.main import main
from gear_phm.estimation import EstimatorSummary
from gear_phm.interfaces import STATUS_KEYS
from gear_phm.jsonfields import JsonValue, RecordError
from gear_phm.offline import analyze_bag
from gear_phm.offline.summary import (DriveSummary, read_summary, RunSummary,
                                      summary_from_dict, TrendSummary)

BAGS = Path(__file__).resolve().parents[2] / 'bags'
#: Two drives of one stream (gear-phm simulate --transmissions), different ratios and wear.
DRIVES = {
    'left': {'motor_joint': 'm_l', 'load_joint': 'out_l', 'ratio': 3.0,
             'simulation': {'wear': 'linear', 'friction_initial': 0.05, 'wear_rate': 2e-3}},
    'right': {'motor_joint': 'm_r', 'load_joint': 'out_r', 'ratio': 5.0,
              'simulation': {'wear': 'constant', 'friction_initial': 0.08}},
}


def _same(a: JsonValue, b: JsonValue) -> bool:
    """Whether two JSON values are equal, NaN equal to NaN, and in the same key order."""
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


@pytest.fixture(scope='module')
def fault(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, DriveSummary]:
    """Return the output directory and summary of bags/fault analysed (R = 3)."""
    out = tmp_path_factory.mktemp('fault') / 'out'
    summary = analyze_bag(BAGS / 'fault', 3.0, out=out, plot=False).summary
    assert isinstance(summary, DriveSummary)
    return out, summary


def test_one_drive_is_read_through_attributes(fault: tuple[Path, DriveSummary]) -> None:
    out, summary = fault
    # bags/fault: u steps from 0.05 to 0.20 at t = 60 s, 12 000 samples at 100 Hz
    assert summary.estimator.u == pytest.approx(0.20, abs=0.002)
    assert summary.estimator.samples_seen == summary.run.messages == 12000
    assert summary.estimator.filter_updates > 0 and not summary.estimator.stalled_stamps()
    assert summary.run.bags == (str(BAGS / 'fault'),) and summary.config.ratio == 3.0
    assert summary.run.samples_per_second == pytest.approx(
        summary.run.messages / summary.run.seconds, rel=1e-12)
    health = summary.health
    assert health.level in ('OK', 'WARN', 'ERROR') and health.message
    assert health.values is not None and tuple(health.values) == STATUS_KEYS
    assert health.value('u') == pytest.approx(summary.estimator.u, abs=0.01)
    assert health.value('rul_p5_s') <= health.value('rul_s') <= health.value('rul_p95_s')
    assert isinstance(health.trend, TrendSummary) and health.trend.u_eol > 0.0
    assert health.first_seen_ns[health.level] >= min(health.first_seen_ns.values())
    assert summary.no_measurement is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        summary.health.level = 'OK'     # type: ignore[misc]


def test_to_dict_is_the_summary_json_written(fault: tuple[Path, DriveSummary]) -> None:
    out, summary = fault
    text = (out / 'summary.json').read_text()
    assert summary.to_json() + '\n' == text
    assert _same(summary.to_dict(), json.loads(text))
    again = read_summary(out)
    assert isinstance(again, DriveSummary)
    assert again.to_json() == summary.to_json()
    assert again.health == summary.health and again.config == summary.config
    assert again.run == summary.run
    # an estimator's optional keys, before 'bag', stay in their place
    items = list(summary.to_dict().items())
    at = [key for key, _ in items].index('bag')
    more = dict([*items[:at], ('part_torque', 0.5), *items[at:]])
    extended = DriveSummary.from_dict(more)
    assert dict(extended.estimator.extra) == {'part_torque': 0.5}
    assert _same(extended.to_dict(), more)


def test_many_drives_read_through_attributes(tmp_path: Path) -> None:
    plan = tmp_path / 'bench.yaml'
    plan.write_text(yaml.safe_dump({'transmissions': DRIVES}, sort_keys=False))
    assert main(['simulate', '--transmissions', str(plan), '--duration', '30', '--out',
                 str(tmp_path / 'bag')]) == 0
    analysis = analyze_bag(tmp_path / 'bag', transmissions=plan, out=tmp_path / 'out',
                           plot=False)
    summary = analysis.summary
    assert isinstance(summary, RunSummary)
    assert list(summary.transmissions) == ['left', 'right'] and summary.run.messages == 3000
    for name, drive in summary.transmissions.items():
        assert drive is analysis.transmissions[name].summary
        assert drive.run.messages == 3000 and drive.health.level != 'none'
    left, right = summary.transmissions['left'], summary.transmissions['right']
    # left wears 0.05 + 2e-3 t: u 0.11 at 30 s; right stays at 0.08
    assert left.estimator.u == pytest.approx(0.11, abs=0.01)
    assert right.estimator.u == pytest.approx(0.08, abs=0.01)
    assert left.config.ratio == 3.0 and right.config.ratio == 5.0
    assert left.health.value('rul_s') < right.health.value('rul_s')
    text = (tmp_path / 'out' / 'summary.json').read_text()
    assert summary.to_json() + '\n' == text
    assert _same(summary.to_dict(), json.loads(text))
    again = read_summary(tmp_path / 'out' / 'summary.json')
    assert isinstance(again, RunSummary) and again.to_json() == summary.to_json()


def test_estimator_summary_is_the_pipeline_dict() -> None:
    values = {'u': 0.1, 'u_rate': 0.0, 'sigma_u': 0.01, 'eta_opposing': 0.9,
              'eta_aiding': 0.88, 'last_measured_efficiency': math.nan, 'filter_updates': 0,
              'samples_seen': 10, 'process_noise': 1e-11, 'mismatch_sigma_opposing': 0.0,
              'mismatch_sigma_aiding': 0.0, 'direction_offset': 0.0,
              'direction_offset_sigma': 0.05, 'direction_offset_drift_z': math.nan,
              'motor_inertia': 0.0, 'operating_time_s': 0.0, 'samples_used': 0,
              'samples_rejected': 10, 'samples_missing': 0, 'sample_period_s': 0.01,
              'counts': {'zero_speed': 4, 'duplicate_stamp': 6}, 'timed_out': False,
              'reversed_torque': '', 'speed_ratio': math.nan, 'ratio_check': '',
              'windows_over_unity': 0, 'over_unity': ''}
    summary = EstimatorSummary.from_dict(values)
    assert _same(summary.to_dict(), values)
    assert summary.stalled_stamps().startswith('the header stamps do not advance: 6 of 10')
    assert summary.unmeasured(0) == ('10 samples, 0 used, 0 windows measured (rejections: '
                                     'duplicate_stamp 6, zero_speed 4)')
    assert dataclasses.replace(summary, filter_updates=1).unmeasured(3) == ''
    # keys of optional parts of the estimator are kept, in order, after the others
    more = {**values, 'part_torque': 0.25, 'part_identified': True, 'part_note': ''}
    kept = EstimatorSummary.from_dict(more)
    assert dict(kept.extra) == {'part_torque': 0.25, 'part_identified': True, 'part_note': ''}
    assert _same(kept.to_dict(), more)
    with pytest.raises(RecordError, match="field 'part_list': expected a number"):
        EstimatorSummary.from_dict({**values, 'part_list': [1.0]})


def test_a_malformed_summary_names_the_field(fault: tuple[Path, DriveSummary],
                                             tmp_path: Path) -> None:
    values = fault[1].to_dict()
    with pytest.raises(RecordError, match="field 'sigma_u' is missing"):
        summary_from_dict({k: v for k, v in values.items() if k != 'sigma_u'})
    with pytest.raises(RecordError, match="field 'filter_updates': expected an integer"):
        summary_from_dict({**values, 'filter_updates': 2.5})
    with pytest.raises(RecordError, match="field 'level': expected a string"):
        summary_from_dict({**values, 'health': {'level': 3}})
    with pytest.raises(RecordError, match='expected a JSON object, got list'):
        summary_from_dict([values])
    (tmp_path / 'summary.json').write_text('{"u": ')
    with pytest.raises(RecordError, match='cannot read .*summary.json'):
        read_summary(tmp_path)
