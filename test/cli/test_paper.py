"""`gear-phm paper`: files, CSV columns, finite statistics, constraints, one-line errors."""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from gear_phm.cli.main import main
from gear_phm.models import min_teeth, SpurGear, total_squared_error

GEAR_PHM = Path(sys.executable).parent / 'gear-phm'


def _finite_numbers(node) -> list[float]:
    if isinstance(node, dict):
        return [x for value in node.values() for x in _finite_numbers(value)]
    if isinstance(node, list):
        return [x for value in node for x in _finite_numbers(value)]
    return [float(node)] if isinstance(node, (int, float)) else []


@pytest.fixture(scope='module')
def paper_run(tmp_path_factory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp('paper') / 'nested' / 'out'
    return out, main(['paper', '--out', str(out), '--samples', '40', '--seed', '7'])


# gear_phm.paper.reproduce (matplotlib, 0.3 s of CPU) is imported by the tests that use it, not
# at collection by every pytest-xdist worker.
def test_writes_figures_csv_and_summary(paper_run) -> None:
    from gear_phm.paper.reproduce import FIGURE_FILES
    out, status = paper_run
    assert status == 0
    for name in FIGURE_FILES:
        data = (out / name).read_bytes()
        assert data[:8] == b'\x89PNG\r\n\x1a\n'
        assert len(data) > 20_000                      # a real plot, not an empty canvas
    assert (out / 'samples.csv').is_file()
    assert (out / 'summary.json').is_file()


def test_csv_has_every_parameter_and_result(paper_run) -> None:
    from gear_phm.paper.reproduce import CSV_COLUMNS
    out, _ = paper_run
    with (out / 'samples.csv').open() as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 40
    assert tuple(rows[0].keys()) == CSV_COLUMNS
    for column in ('z1', 'z2', 'module_m', 'pressure_angle_deg', 'tooth_friction',
                   'bearing_radius_1_m', 'bearing_radius_2_m', 'ratio', 'eta_opposing',
                   'eta_aiding', 'error_opposing', 'error_aiding', 'e_tot'):
        assert column in rows[0]
    for row in rows:
        z1, z2 = float(row['z1']), float(row['z2'])
        theta = math.radians(float(row['pressure_angle_deg']))
        assert z1 == round(z1) and z2 == round(z2)
        assert min(z1, z2) >= float(min_teeth(theta))
        assert 0.1 <= float(row['ratio']) <= 50.0
        assert float(row['ratio']) == z2 / z1
        gear = SpurGear(z1, z2, float(row['module_m']), theta, float(row['addendum_m']),
                        float(row['tooth_friction']), float(row['bearing_radius_1_m']),
                        float(row['bearing_radius_2_m']))
        eta_d, eta_i = gear.efficiencies()
        assert float(row['eta_opposing']) == pytest.approx(eta_d, rel=1e-12)
        assert float(row['eta_aiding']) == pytest.approx(eta_i, rel=1e-12)
        expected = total_squared_error(eta_d, eta_i, z2 / z1)
        if math.isnan(expected):
            assert math.isnan(float(row['e_tot']))
        else:
            assert float(row['e_tot']) == pytest.approx(expected, rel=1e-9, abs=1e-30)


def test_summary_statistics_are_finite_and_consistent(paper_run) -> None:
    out, _ = paper_run
    summary = json.loads((out / 'summary.json').read_text())
    assert summary['samples'] == 40
    assert summary['seed'] == 7
    numbers = _finite_numbers(summary)
    assert numbers and all(math.isfinite(x) for x in numbers)
    e_tot = summary['e_tot']
    assert 0.0 <= e_tot['min'] <= e_tot['median'] <= e_tot['p95'] <= e_tot['max']
    assert 0.0 <= summary['e_tot_fraction_below_1e-2'] <= 1.0
    with (out / 'samples.csv').open() as stream:
        values = np.array([float(r['e_tot']) for r in csv.DictReader(stream)])
    assert e_tot['median'] == pytest.approx(float(np.nanmedian(values)), rel=1e-12)
    # Tooth friction alone: the simplified model is nearly exact (paper's main claim).
    assert summary['ideal_bearings_same_samples']['e_tot']['max'] < 1e-4
    limit = summary['large_ratio_limit']['eta_aiding_at_eta_opposing_0.5_R_1e+06']
    assert abs(limit) < 1e-5


def test_sampling_is_seeded() -> None:
    from gear_phm.paper.reproduce import sample_reference_gears
    first, again = sample_reference_gears(30, 3), sample_reference_gears(30, 3)
    other = sample_reference_gears(30, 4)
    for name in first:
        assert np.array_equal(first[name], again[name])
    assert not np.array_equal(first['z1'], other['z1'])


def test_existing_file_as_out_is_a_one_line_error(tmp_path) -> None:
    target = tmp_path / 'not-a-dir'
    target.write_text('x')
    result = subprocess.run([str(GEAR_PHM), 'paper', '--out', str(target), '--samples', '5'],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stdout == ''
    lines = result.stderr.strip().splitlines()
    assert lines == [f"gear-phm paper: error: --out '{target}' exists and is not a "
                     'directory']
    assert target.read_text() == 'x'


def test_out_below_a_file_is_a_one_line_error(tmp_path, capsys) -> None:
    target = tmp_path / 'file'
    target.write_text('x')
    assert main(['paper', '--out', str(target / 'sub'), '--samples', '5']) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1
    assert error[0].startswith(f'gear-phm paper: error: cannot create --out directory '
                               f"'{target / 'sub'}'")


@pytest.mark.parametrize('arguments', [['--samples', '0'], ['--samples', 'many'],
                                       ['--seed', '-1'], ['--max-bearing-fraction', '-1'],
                                       ['--max-bearing-fraction', 'x']])
def test_bad_numbers_exit_2(tmp_path, capsys, arguments) -> None:
    with pytest.raises(SystemExit) as info:
        main(['paper', '--out', str(tmp_path), *arguments])
    assert info.value.code == 2
    assert arguments[0] in capsys.readouterr().err


def test_bounded_numbers_refuse_with_the_range() -> None:
    import argparse

    from gear_phm.cli.paper import _bounded
    count, share = _bounded(int, 1), _bounded(float, 0.0, 2.0)
    assert count('3') == 3 and share('2') == 2.0 and share('0') == 0.0
    for parse, text, message in ((count, '0', 'must be >= 1, got 0'),
                                 (count, '1.5', "expected a whole number, got '1.5'"),
                                 (share, '2.5', 'must be in [0, 2], got 2.5'),
                                 (share, 'x', "expected a number, got 'x'")):
        with pytest.raises(argparse.ArgumentTypeError) as caught:
            parse(text)
        assert str(caught.value) == message
