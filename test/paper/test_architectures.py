"""gear_phm.paper.architectures: samplers, the direction offset, the table."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gear_phm.models import eta_aiding, eta_opposing
from gear_phm.paper.architectures import (ArchitectureRanges, direction_offsets, SAMPLED,
                                          table_row, write_table)
from gear_phm.paper.reproduce import compare_with_lever, SamplingRanges


def test_direction_offset_is_zero_on_the_lever_and_the_gap_of_the_readings() -> None:
    ratio = np.array([2.0, 40.0, 1256.6])
    u_d, u_i = np.array([0.1, 0.3, 0.05]), np.array([0.1, 0.35, 0.02])
    on_curve = compare_with_lever(np.asarray(eta_opposing(u_d, ratio)),
                                  np.asarray(eta_aiding(u_d, ratio)), ratio)
    assert np.allclose(direction_offsets(on_curve), 0.0, atol=1e-12)
    off_curve = compare_with_lever(np.asarray(eta_opposing(u_d, ratio)),
                                   np.asarray(eta_aiding(u_i, ratio)), ratio)
    assert np.allclose(direction_offsets(off_curve), u_i - u_d, rtol=1e-9, atol=1e-12)


def test_jammed_samples_have_no_lever_image() -> None:
    table = compare_with_lever(np.array([math.nan, 0.8]), np.array([0.3, 0.7]),
                               np.array([10.0, 10.0]))
    assert math.isnan(table['e_tot'][0]) and math.isfinite(table['e_tot'][1])
    assert math.isnan(direction_offsets(table)[0])


@pytest.mark.parametrize('name', sorted(SAMPLED))
def test_samplers_are_seeded_and_physical(name: str) -> None:
    sampler = SAMPLED[name].sampler
    first = sampler(60, 3, SamplingRanges(), ArchitectureRanges())
    again = sampler(60, 3, SamplingRanges(), ArchitectureRanges())
    other = sampler(60, 4, SamplingRanges(), ArchitectureRanges())
    assert all(np.array_equal(first[k], again[k], equal_nan=True) for k in first)
    assert not np.array_equal(first['eta_opposing'], other['eta_opposing'], equal_nan=True)
    assert all(values.shape == (60,) for values in first.values())
    assert np.all(first['ratio'] > 0.0)
    defined = np.isfinite(first['eta_opposing'])
    assert np.all(first['eta_opposing'][defined] <= 1.0)
    assert np.all(first['eta_aiding'][defined] <= 1.0)
    assert np.all(first['eta_aiding'][defined] < first['eta_opposing'][defined] + 0.5)


def test_self_locking_samples_are_those_with_negative_aiding_efficiency() -> None:
    for name in ('worm', 'screw'):
        table = SAMPLED[name].sampler(200, 1, SamplingRanges(), ArchitectureRanges())
        locking = table['self_locking'] == 1.0
        assert locking.any() and (~locking).any()
        assert np.array_equal(locking, table['eta_aiding'] <= 0.0)


def test_table_markdown_and_csv(tmp_path) -> None:
    summary = {'samples': 10, 'ratio': {'p5': 2.0, 'p95': 40.0}, 'irreversible_fraction': 0.1,
               'no_image_on_curve': 0, 'e_tot': {'median': 1.23e-5, 'p95': 4e-4},
               'abs_error_aiding': {'p95': 0.05}, 'abs_direction_offset': {'median': 0.007,
                                                                           'p95': 0.06}}
    text = write_table([table_row('worm', summary)], tmp_path)
    assert text.splitlines()[2] == '| worm | 10 | 2 | 40 | 0.1 | 0 | 1.2e-05 | 0.0004 | 0.05 | ' \
                                   '0.007 | 0.06 |'
    assert (tmp_path / 'table.csv').read_text().splitlines()[1].startswith('worm,10.0,2.0,')
