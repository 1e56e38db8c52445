"""Command-line options built from the parameter specs (:class:`gear_phm.parameters.ParamSpec`)."""
from __future__ import annotations

import argparse
from collections.abc import Callable
import math
from typing import Any

from gear_phm.cli.main import CliError
from gear_phm.estimation.config import PARAMETERS as ESTIMATOR_PARAMETERS
from gear_phm.parameters import ParamSpec, RATIO, spec_map
from gear_phm.prognostics.config import NOT_OFFLINE_OPTIONS
from gear_phm.prognostics.config import PARAMETERS as HEALTH_PARAMETERS

_PREFIX = 'health_'


def _integer(text: str) -> int:
    """Parse an integer option: also an integral float such as ``1e5`` (ranges print so)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not value.is_integer():
        msg = f'invalid integer: {text!r}'
        raise argparse.ArgumentTypeError(msg) from None
    return int(value)


def option_type(spec: ParamSpec) -> Callable[[str], Any]:
    """Return the argparse ``type`` of a number parameter's option."""
    return _integer if spec.kind is int else spec.kind


def _help(spec: ParamSpec) -> str:
    text = spec.description.replace('%', '%%')
    if spec.kind is bool:
        return text
    if spec.choices:
        return f'{text} (default {spec.default})'
    low = '-inf' if spec.low is None else f'{spec.low:g}'
    high = 'inf' if spec.high is None else f'{spec.high:g}'
    default = f'nan, {spec.nan_means}' if spec.nan_means else spec.default
    return f'{text} [{spec.unit}], in [{low}, {high}] (default {default})'


def add_health_arguments(parser: argparse.ArgumentParser) -> None:
    """Add one option per health parameter but :data:`NOT_OFFLINE_OPTIONS`: ``--u-max``, ...

    ``--must-back-drive``/``--no-must-back-drive`` for the flag; read them back with
    :func:`health_values`.
    """
    group = parser.add_argument_group('health and end of life (diagnostics)')
    for spec in HEALTH_PARAMETERS:
        if spec.name in NOT_OFFLINE_OPTIONS:
            continue
        option = '--' + spec.name.replace('_', '-')
        if spec.kind is bool:
            group.add_argument(option, dest=_PREFIX + spec.name,
                               action=argparse.BooleanOptionalAction, default=spec.default,
                               help=f'{_help(spec)} (default {spec.default})')
        elif spec.choices:
            group.add_argument(option, dest=_PREFIX + spec.name, choices=spec.choices,
                               default=spec.default, help=_help(spec))
        else:
            group.add_argument(option, dest=_PREFIX + spec.name, type=option_type(spec),
                               default=spec.default,
                               metavar=spec.unit.upper() if spec.unit != '-' else 'VALUE',
                               help=_help(spec))


def health_values(args: argparse.Namespace) -> dict[str, Any]:
    """Return the health parameter values of :func:`add_health_arguments`'s options."""
    return {key[len(_PREFIX):]: value for key, value in vars(args).items()
            if key.startswith(_PREFIX)}


def estimator_params(items: list[str]) -> dict[str, Any]:
    """``--param NAME=VALUE`` items as estimator parameter values (CliError if malformed)."""
    table = spec_map(ESTIMATOR_PARAMETERS)
    values: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition('=')
        if not sep:
            raise CliError(f'--param expects NAME=VALUE, got {item!r}')
        if name not in table or name == RATIO.name:
            known = ', '.join(sorted(set(table) - {RATIO.name}))
            raise CliError(f'--param: unknown estimator parameter {name!r} (known: {known})')
        try:
            values[name] = table[name].parse(text)
        except ValueError as exc:
            raise CliError(f'--param {exc}') from None
    return values
