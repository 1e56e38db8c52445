"""ParamSpec and the config fields that declare it (gear_phm/parameters.py).

The derived PARAMETERS of the config dataclasses are compared with the specs recorded in
test/data/parameter_specs.json (name, default and its type, description, unit, range,
choices, flags, order). After a deliberate change of a parameter, rewrite that file with
``.venv/bin/python test/toplevel/test_parameters.py`` and review its diff.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, is_dataclass
import importlib
import json
import math
from pathlib import Path
import sys
from typing import Any

import pytest

from gear_phm.estimation.config import EstimatorConfig
from gear_phm.parameters import (check_values, LOAD_JOINT, param, param_from, ParamSpec, RATIO,
                                 SPEC, spec_map, specs_of)
from gear_phm.prognostics.config import HealthConfig

RECORDED = Path(__file__).resolve().parents[1] / 'data' / 'parameter_specs.json'
#: The modules whose PARAMETERS are derived from a config dataclass, with that dataclass.
CONFIGS = {'gear_phm.estimation.config': EstimatorConfig,
           'gear_phm.prognostics.config': HealthConfig}


def _records(specs: tuple[ParamSpec, ...]) -> list[dict[str, Any]]:
    return [dict(asdict(spec), choices=list(spec.choices)) for spec in specs]


def _typed(record: dict[str, Any]) -> dict[str, tuple[str, str]]:
    """Each value as (type name, repr): 1 and 1.0 differ, NaN equals NaN."""
    return {key: (type(value).__name__, repr(value)) for key, value in record.items()}


@pytest.mark.parametrize('module', sorted(CONFIGS))
def test_derived_parameters_equal_the_recorded_specs(module: str) -> None:
    recorded = json.loads(RECORDED.read_text())[module]
    derived = _records(importlib.import_module(module).PARAMETERS)
    assert [r['name'] for r in derived] == [r['name'] for r in recorded]
    for got, want in zip(derived, recorded):
        assert _typed(got) == _typed(want)


@pytest.mark.parametrize('module', sorted(CONFIGS))
def test_parameters_follow_the_fields(module: str) -> None:
    config = CONFIGS[module]
    namespace = importlib.import_module(module)
    assert [s.name for s in namespace.PARAMETERS] == [f.name for f in fields(config)]
    default = config()
    for spec in namespace.PARAMETERS:
        value = getattr(default, spec.name)
        assert type(value) is spec.kind
        assert value == spec.default or (math.isnan(value) and math.isnan(spec.default))
        assert namespace.DEFAULTS[spec.name] is spec.default
    assert namespace.PARAMETERS[0] is RATIO


@dataclass(frozen=True)
class _Example:
    ratio: float = param_from(RATIO, float)
    joint: str = param_from(LOAD_JOINT, str)
    noise: float = param(0.01, 'std dev of one sample', 'N m', 0.0, 1e6)
    count: int = param(3, 'how many', '-', 1, 10, read_only=True)
    mode: str = param('a', 'the mode', choices=('a', 'b'))
    flag: bool = param(True, 'a flag')
    level: float = param(math.nan, 'a level', '-', 0.0, 1.0, nan_means='derived')


def test_specs_of_names_each_spec_after_its_field() -> None:
    specs = specs_of(_Example)
    assert [s.name for s in specs] == ['ratio', 'joint', 'noise', 'count', 'mode', 'flag',
                                       'level']
    assert specs[0] is RATIO
    assert specs[1] == ParamSpec('joint', 'load', LOAD_JOINT.description, read_only=True)
    assert specs[2] == ParamSpec('noise', 0.01, 'std dev of one sample', 'N m', 0.0, 1e6)
    assert specs[3] == ParamSpec('count', 3, 'how many', '-', 1, 10, read_only=True)
    assert specs[4] == ParamSpec('mode', 'a', 'the mode', choices=('a', 'b'))
    assert specs[5] == ParamSpec('flag', True, 'a flag')
    assert specs[6].nan_means == 'derived' and math.isnan(specs[6].check(math.nan))


def test_param_fields_hold_their_default_and_spec() -> None:
    example = _Example()
    assert (example.ratio, example.joint, example.noise, example.count, example.mode,
            example.flag) == (3.0, 'load', 0.01, 3, 'a', True)
    assert math.isnan(example.level)
    assert _Example(noise=0.5, count=4).noise == 0.5
    by_name = {f.name: f for f in fields(_Example)}
    assert by_name['noise'].metadata[SPEC].description == 'std dev of one sample'
    assert by_name['ratio'].metadata[SPEC] is RATIO


def test_param_from_refuses_another_type() -> None:
    with pytest.raises(TypeError, match='ratio: default 3.0 is not of type int'):
        param_from(RATIO, int)


def test_specs_of_refuses_a_field_without_a_spec() -> None:
    @dataclass(frozen=True)
    class Plain:
        noise: float = param(0.01, 'std dev')
        other: float = 1.0

    with pytest.raises(TypeError, match=r'Plain\.other is not declared by param\(\)'):
        specs_of(Plain)


def test_specs_of_refuses_an_annotation_unlike_the_default() -> None:
    @dataclass(frozen=True)
    class Mistyped:
        noise: float = param(1, 'std dev', '-', 0, 10)  # an int default: an int parameter

    with pytest.raises(TypeError, match="Mistyped.noise is annotated 'float' but its default "
                                        '1 is of type int'):
        specs_of(Mistyped)


def test_specs_of_refuses_a_spec_that_is_not_a_paramspec() -> None:
    @dataclass(frozen=True)
    class Foreign:
        noise: float = field(default=0.5, metadata={SPEC: 'not a spec'})

    with pytest.raises(TypeError, match='Foreign.noise is not declared'):
        specs_of(Foreign)
    assert is_dataclass(Foreign)


def test_config_validation_names_the_parameter_and_the_rule() -> None:
    with pytest.raises(ValueError, match=r'^motor_torque_noise must be in \[0, 1e\+06\] N m, '
                                         r'got -1\.0$'):
        EstimatorConfig(motor_torque_noise=-1.0)
    with pytest.raises(ValueError, match=r'^min_window must be < window \(1\.0 s\), got 2\.0$'):
        EstimatorConfig(window=1.0, min_window=2.0)
    with pytest.raises(ValueError, match=r'^motor_effort_sign must be 1 or -1, got 0$'):
        EstimatorConfig(motor_effort_sign=0)
    with pytest.raises(ValueError, match=r'^backwards_policy must be one of reset, skip, '
                                         r"got 'loop'$"):
        EstimatorConfig(backwards_policy='loop')
    with pytest.raises(ValueError, match=r'^eta_warn must be > eta_opposing_min \(0\.5\)'):
        HealthConfig(eta_warn=0.4)
    with pytest.raises(ValueError, match=r'^eta_opposing_min must be > -1/ratio = -0\.6667'):
        HealthConfig(ratio=1.5, eta_opposing_min=-0.8)
    with pytest.raises(ValueError, match=r"^unknown estimator parameter\(s\): \['nope'\]$"):
        EstimatorConfig().replace(nope=1.0)
    assert EstimatorConfig().replace(window=2.0).window == 2.0
    assert HealthConfig().replace(trend='linear').as_dict()['trend'] == 'linear'


def test_check_converts_and_bounds() -> None:
    count = ParamSpec('count', 3, 'how many', '-', 1, 10)
    assert count.check(4.0) == 4 and type(count.check(4.0)) is int
    with pytest.raises(ValueError, match='count must be an integer, got 4.5'):
        count.check(4.5)
    with pytest.raises(ValueError, match=r'count must be in \[1, 10\], got 11'):
        count.check(11)
    with pytest.raises(ValueError, match='count must be a number \\[-\\], got True'):
        count.check(True)
    assert type(RATIO.check(2)) is float
    with pytest.raises(ValueError, match=r'ratio must be in \[1e-06, 1e\+06\], got nan'):
        RATIO.check(math.nan)
    assert RATIO.parse('2.5') == 2.5
    with pytest.raises(ValueError, match="ratio needs a number, got 'x'"):
        RATIO.parse('x')
    assert ParamSpec('flag', True, 'a flag').parse('0') is False


def test_check_values_and_spec_map_refuse_unknown_and_repeated_names() -> None:
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['other'\]"):
        check_values((RATIO,), {'other': 1.0})
    with pytest.raises(ValueError, match='parameter ratio is specified twice'):
        spec_map((RATIO, RATIO))


def _write_recorded() -> None:
    """Record today's derived PARAMETERS of each config module (review the diff)."""
    text = json.dumps({module: _records(importlib.import_module(module).PARAMETERS)
                       for module in sorted(CONFIGS)}, indent=1)
    RECORDED.write_text(text + '\n')
    print(f'wrote {RECORDED}', file=sys.stderr)


if __name__ == '__main__':
    _write_recorded()
