"""The no-load model through ``gear-phm simulate`` and ``gear-phm analyze --param``.

A healthy lever gearbox (R 30, u 0.0595: eta_D 0.942, eta_I 0.940) with a Coulomb drag at the
motor of 2.5 % of its input torque when warm and three times that cold, from a cold start:
with a load that varies from cycle to cycle the model separates the drag from the friction;
under a constant load it cannot, and says so without an alarm.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path
import struct

import pytest

from gear_phm.cli.main import main as gear_phm
from gear_phm.models.lever import eta_aiding, eta_opposing
from gear_phm.offline import read_summary

pytestmark = pytest.mark.integration

RATIO = 30.0
U = 0.0595
DRAG = ['--ratio', '30', '--wear', 'constant', '--friction-initial', str(U),
        '--no-load-coulomb', '0.034', '--no-load-cold-factor', '3',
        '--oil-warm-time-constant', '900']
ANALYZE = ['--ratio', '30', '--eta-opposing-min', '0.9148', '--no-plot', '--no-progress']


def health_levels(out: Path) -> list[str]:
    """Return the level names of the health statuses in an analysis output bag."""
    from rosbags.highlevel import AnyReader

    names = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}
    levels = []
    with AnyReader([out]) as reader:
        connections = [c for c in reader.connections if c.topic == '/diagnostics']
        for connection, _, raw in reader.messages(connections=connections):
            message = reader.deserialize(raw, connection.msgtype)
            levels += [names[int.from_bytes(bytes([s.level]) if isinstance(s.level, int)
                                            else s.level, 'little')]
                       for s in message.status if s.name.startswith('gear_phm: ')]
    assert levels
    return levels


def _simulate(out: Path, *options: str) -> Path:
    assert gear_phm(['simulate', '--out', str(out), '--duration', '600', '--rate', '100',
                     *DRAG, *options]) == 0          # a later --duration wins
    return out


def test_drag_on_a_varying_load_is_separated_from_friction(tmp_path: Path) -> None:
    bag = _simulate(tmp_path / 'bag', '--load-scale-min', '0.3', '--load-scale-max', '1.0',
                    '--bias-effort-load', '0.4')
    assert gear_phm(['analyze', str(bag), *ANALYZE[:-2], '--no-progress', '--param',
                     'no_load_model=true', '--out', str(tmp_path / 'on')]) == 0
    # the plot gains a panel of the no-load torque: 13.5 in high at 110 dpi instead of 11
    assert struct.unpack('>II', (tmp_path / 'on' / 'analysis.png').read_bytes()[16:24]) == (
        1100, 1485)
    on = read_summary(tmp_path / 'on').estimator
    assert on.eta_opposing == pytest.approx(float(eta_opposing(U, RATIO)), abs=0.01)
    assert on.eta_aiding == pytest.approx(float(eta_aiding(U, RATIO)), abs=0.01)
    assert on.extra['no_load_identified'] is True
    assert on.extra['no_load_torque'] > 0.034       # still above the warm drag at 10 min
    assert set(health_levels(tmp_path / 'on')) == {'OK'}
    # the paper's model reads the same drag as wear
    assert gear_phm(['analyze', str(bag), *ANALYZE, '--out', str(tmp_path / 'off')]) == 0
    off = read_summary(tmp_path / 'off').estimator
    assert off.eta_opposing < float(eta_opposing(U, RATIO)) - 0.015
    assert 'ERROR' in health_levels(tmp_path / 'off')


def test_drag_under_a_constant_load_is_not_identifiable_and_no_alarm(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = _simulate(tmp_path / 'bag', '--air-load-stiffness', '0')
    assert gear_phm(['analyze', str(bag), *ANALYZE, '--param', 'no_load_model=true',
                     '--out', str(tmp_path / 'on')]) == 0
    assert 'not identifiable' in capsys.readouterr().out        # the result: stdout
    summary = json.loads((tmp_path / 'on' / 'summary.json').read_text())
    assert summary['filter_updates'] == 0
    assert summary['counts']['not_identifiable'] > 100
    assert set(health_levels(tmp_path / 'on')) == {'OK'}


def test_fleet_table_holds_the_no_load_torque(tmp_path: Path) -> None:
    unit = tmp_path / 'fleet' / 'unit_a'
    unit.mkdir(parents=True)
    _simulate(unit / 'rec_1', '--load-scale-min', '0.3', '--load-scale-max', '1.0',
              '--duration', '300')
    out = tmp_path / 'out'
    assert gear_phm(['fleet', str(tmp_path / 'fleet'), '--ratio', '30', '--out', str(out),
                     '--param', 'no_load_model=true', '--workers', '1', '--no-plot']) == 0
    with (out / 'fleet.csv').open() as handle:
        row = next(csv.DictReader(handle))
    # cold: above the warm drag, below its cold value
    assert 0.034 < float(row['no_load_torque']) < 3.0 * 0.034
    assert row['total_efficiency'] == 'nan'             # no rated point given
