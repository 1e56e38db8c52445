"""Options built from the parameter specs (gear_phm.cli.options): types, health, --param."""
from __future__ import annotations

import argparse
import math

import pytest

from gear_phm.cli.main import CliError
from gear_phm.cli.options import (add_health_arguments, estimator_params, health_values,
                                  option_type)
from gear_phm.estimation.config import PARAMETERS as ESTIMATOR_PARAMETERS
from gear_phm.parameters import spec_map
from gear_phm.prognostics.config import PARAMETERS as HEALTH_PARAMETERS


def test_integer_options_take_integral_floats_only() -> None:
    parse = option_type(spec_map(HEALTH_PARAMETERS)['mc_samples'])
    assert parse('2000') == 2000 and parse('1e5') == 100_000 and isinstance(parse('1e5'), int)
    for text in ('1.5', 'many', 'nan'):
        with pytest.raises(argparse.ArgumentTypeError, match=f"invalid integer: '{text}'"):
            parse(text)
    assert option_type(spec_map(HEALTH_PARAMETERS)['detect_z']) is float


def test_health_options_default_to_the_specs_and_read_back_by_name() -> None:
    parser = argparse.ArgumentParser()
    add_health_arguments(parser)
    defaults = health_values(parser.parse_args([]))
    offline = {s.name: s.default for s in HEALTH_PARAMETERS
               if s.name not in ('ratio', 'stale_timeout')}
    assert set(defaults) == set(offline)          # ratio and stale_timeout: no option
    assert math.isnan(defaults.pop('eta_warn')) and math.isnan(offline.pop('eta_warn'))
    assert defaults == offline
    values = health_values(parser.parse_args(['--must-back-drive', '--trend', 'linear',
                                              '--mc-samples', '5e3', '--warn-horizon', '60']))
    assert (values['must_back_drive'], values['trend'], values['mc_samples'],
            values['warn_horizon']) == (True, 'linear', 5000, 60.0)
    with pytest.raises(SystemExit):
        parser.parse_args(['--ratio', '3'])


def test_estimator_params_parse_by_the_spec_and_refuse_with_one_line() -> None:
    assert estimator_params(['window=2', 'motor_effort_sign=-1', 'learn_motor_inertia=false']) \
        == {'window': 2.0, 'motor_effort_sign': -1, 'learn_motor_inertia': False}
    assert estimator_params([]) == {}
    with pytest.raises(CliError, match="^--param expects NAME=VALUE, got 'window'$"):
        estimator_params(['window'])
    with pytest.raises(CliError, match="^--param: unknown estimator parameter 'ratio'"):
        estimator_params(['ratio=3'])                    # --ratio is its own option
    with pytest.raises(CliError, match="unknown estimator parameter 'windw'"):
        estimator_params(['windw=2'])
    with pytest.raises(CliError, match='^--param .*window'):
        estimator_params(['window=-1'])
    assert 'window' in spec_map(ESTIMATOR_PARAMETERS)
