"""`gear-phm paper --architecture`: the lever model against each architecture's reference."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from gear_phm.cli.main import main
from gear_phm.models import LeadScrew, PlanetaryGearSet, total_squared_error, WormGear

SAMPLES = 24


@pytest.mark.long(10)
def test_all_architectures(tmp_path) -> None:
    """One run of every architecture (the plots dominate), checked three ways below."""
    out = tmp_path / 'out'
    status = main(['paper', '--out', str(out), '--architecture', 'all', '--samples',
                   str(SAMPLES), '--seed', '11'])
    assert status == 0
    run = (out, status, (out / 'table.md').read_text())
    check_every_architecture_has_its_figures_samples_and_summary(run)
    check_table_numbers_are_finite_and_consistent(run)
    check_samples_are_the_reference_models(run)


def _table(out: Path) -> list[dict[str, str]]:
    with (out / 'table.csv').open() as stream:
        return list(csv.DictReader(stream))


def check_every_architecture_has_its_figures_samples_and_summary(all_run) -> None:
    from gear_phm.paper.architectures import ARCHITECTURES, figure_files
    out, status, _ = all_run
    assert status == 0
    for name in ARCHITECTURES:
        for figure in figure_files(name):
            data = (out / name / figure).read_bytes()
            assert data[:8] == b'\x89PNG\r\n\x1a\n'
            assert len(data) > 20_000                    # a real plot
        summary = json.loads((out / name / 'summary.json').read_text())
        assert summary['samples'] == SAMPLES
        with (out / name / 'samples.csv').open() as stream:
            assert len(list(csv.DictReader(stream))) == SAMPLES


def check_table_numbers_are_finite_and_consistent(all_run) -> None:
    from gear_phm.paper.architectures import ARCHITECTURES, TABLE_COLUMNS
    out, _, markdown = all_run
    rows = _table(out)
    assert [row['architecture'] for row in rows] == list(ARCHITECTURES)
    for row in rows:
        assert tuple(row) == TABLE_COLUMNS
        numbers = {key: float(value) for key, value in row.items() if key != 'architecture'}
        assert all(math.isfinite(value) for value in numbers.values()), row
        assert numbers['samples'] == SAMPLES
        assert 0.0 <= numbers['e_tot_median'] <= numbers['e_tot_p95']
        assert 0.0 <= numbers['irreversible_fraction'] <= 1.0
        assert 0.0 < numbers['ratio_p5'] <= numbers['ratio_p95']
        summary = json.loads((out / row['architecture'] / 'summary.json').read_text())
        assert numbers['e_tot_median'] == summary['e_tot']['median']
        assert f'| {row["architecture"]} | {SAMPLES} |' in markdown
    # A screw's R is 2 pi / lead in rad/m: hundreds to thousands.
    screw = next(row for row in rows if row['architecture'] == 'screw')
    assert float(screw['ratio_p5']) > 50.0


def check_samples_are_the_reference_models(all_run) -> None:
    out, _, _ = all_run
    with (out / 'worm' / 'samples.csv').open() as stream:
        for row in csv.DictReader(stream):
            worm = WormGear(math.radians(float(row['lead_angle_deg'])), float(row['starts']),
                            float(row['wheel_teeth']),
                            math.radians(float(row['normal_pressure_angle_deg'])),
                            float(row['friction']))
            assert (float(row['eta_opposing']), float(row['eta_aiding'])) == pytest.approx(
                worm.efficiencies(), rel=1e-9)
            assert float(row['self_locking']) == float(worm.self_locking)
            assert float(row['e_tot']) == pytest.approx(total_squared_error(
                *worm.efficiencies(), worm.ratio), rel=1e-9, abs=1e-30)
    with (out / 'screw' / 'samples.csv').open() as stream:
        for row in csv.DictReader(stream):
            assert float(row['ratio']) == pytest.approx(2 * math.pi / float(row['lead_m']))
            if row['kind'] == '0.0':
                screw = LeadScrew(float(row['lead_m']), float(row['diameter_m']),
                                  math.radians(float(row['flank_or_contact_angle_deg'])),
                                  float(row['friction']))
                assert float(row['eta_aiding']) == pytest.approx(screw.efficiencies()[1])
    with (out / 'planetary' / 'samples.csv').open() as stream:
        rows = list(csv.DictReader(stream))
    single = [row for row in rows if row['stages'] == '1.0']
    assert single, 'no single-stage planetary sample drawn'
    assert all(np.isfinite(float(row['e_tot'])) for row in rows)
    assert all(float(row['k_first']) > 1.0 for row in rows)


def test_one_architecture_writes_into_out(tmp_path, capsys) -> None:
    out = tmp_path / 'worm'
    assert main(['paper', '--out', str(out), '--architecture', 'worm', '--samples', '8']) == 0
    printed = capsys.readouterr().out
    assert '| worm | 8 |' in printed
    assert (out / 'fig4_worm_comparison.png').is_file()
    assert len(_table(out)) == 1


def test_planetary_reference_in_samples_is_consistent() -> None:
    from gear_phm.paper.architectures import ArchitectureRanges, sample_planetary
    from gear_phm.paper.reproduce import SamplingRanges
    first = sample_planetary(40, 5, SamplingRanges(), ArchitectureRanges())
    again = sample_planetary(40, 5, SamplingRanges(), ArchitectureRanges())
    assert all(np.array_equal(first[k], again[k], equal_nan=True) for k in first)
    # Ring fixed, sun driving, one stage: the closed form of the reducer.
    gear = PlanetaryGearSet(20, 30, friction=0.1)
    eta0 = gear.basic_efficiencies()[0]
    assert gear.efficiencies()[0] == pytest.approx((1 + 4 * eta0) / 5, rel=1e-12)


def test_unknown_architecture_exits_2_and_writes_nothing(tmp_path, capsys) -> None:
    out = tmp_path / 'none'
    with pytest.raises(SystemExit) as info:
        main(['paper', '--out', str(out), '--architecture', 'bevel'])
    assert info.value.code == 2
    assert "invalid choice: 'bevel'" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize('value', ['-0.1', '3', 'x'])
def test_bad_tooth_friction_bound_exits_2(tmp_path, capsys, value: str) -> None:
    with pytest.raises(SystemExit) as info:
        main(['paper', '--out', str(tmp_path / 'x'), '--max-tooth-friction', value])
    assert info.value.code == 2
    assert '--max-tooth-friction' in capsys.readouterr().err
    assert not (tmp_path / 'x').exists()


def test_tooth_friction_bound_reaches_the_gear_samples(tmp_path) -> None:
    out = tmp_path / 'helical'
    assert main(['paper', '--out', str(out), '--architecture', 'helical', '--samples', '30',
                 '--max-tooth-friction', '0.05', '--max-bearing-fraction', '0.05']) == 0
    with (out / 'samples.csv').open() as stream:
        rows = list(csv.DictReader(stream))
    assert max(float(row['tooth_friction']) for row in rows) <= 0.05
    assert max(float(row['bearing_fraction_1']) for row in rows) <= 0.05
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['sampling_ranges']['tooth_friction'] == [0.0, 0.05]
    assert summary['e_tot']['p95'] < 1e-3          # small losses: the lever holds closely
