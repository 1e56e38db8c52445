"""Command-line options for the health parameters (used by ``gear-phm analyze``)."""
from __future__ import annotations

import argparse

from gear_phm.prognostics.config import HealthConfig, PARAMETERS, TRENDS

_SKIP = ('ratio', 'stale_timeout')   # analyze takes the ratio from its estimator options


def add_health_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--eta-opposing-min``, ``--u-max``, ``--eta-warn``, ... (defaults of HealthConfig).

    ``--ratio`` and ``--stale-timeout`` are not added: the caller passes the ratio it already
    has to :func:`health_config_from_args`; staleness is a live-only concept.
    """
    defaults = HealthConfig()
    group = parser.add_argument_group('health and end of life (diagnostics)')
    for name, (low, high, unit, description) in PARAMETERS.items():
        if name in _SKIP:
            continue
        default = getattr(defaults, name)
        text = description.replace('%', '%%')
        group.add_argument('--' + name.replace('_', '-'), dest='health_' + name,
                           type=type(default), default=default, metavar=unit.upper()
                           if unit != '-' else 'VALUE',
                           help=f'{text} [{unit}], in [{low:g}, {high:g}] '
                                f'(default {default})')
    group.add_argument('--no-self-locking-eol', dest='health_self_locking_eol',
                       action='store_false', default=defaults.self_locking_eol,
                       help='do not count the self-locking onset (eta_I <= 0, u >= 1) as end '
                            'of life')
    group.add_argument('--trend', dest='health_trend', choices=TRENDS, default=defaults.trend,
                       help='RUL extrapolation: auto (exponential when u accelerates), linear '
                            'or exponential (default auto)')


def health_config_from_args(args: argparse.Namespace, ratio: float) -> HealthConfig:
    """Build a HealthConfig from parsed options and the gearbox ``ratio``; ValueError."""
    values = {key[len('health_'):]: value for key, value in vars(args).items()
              if key.startswith('health_')}
    return HealthConfig(ratio=float(ratio), **values)
