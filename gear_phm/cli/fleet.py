"""``gear-phm fleet ROOT --ratio R --out DIR``: every unit of a fleet, in parallel on Dask.

ROOT holds one folder of recordings per unit (see :mod:`gear_phm.offline.fleet`). Writes
DIR/fleet.parquet, DIR/fleet.csv (one row per unit), DIR/fleet.png (not with --no-plot),
DIR/fleet_run.json and each unit's analysis under DIR/units/<unit>/.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys

from gear_phm.cli.main import CliError
from gear_phm.cli.options import add_health_arguments, estimator_params, health_values
from gear_phm.offline.fleet import CONNECT_TIMEOUT

HELP = 'analyse a fleet: one folder of recordings per unit, units in parallel on Dask'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('root', type=Path, help='folder with one sub-folder per unit')
    parser.add_argument('--ratio', type=float, default=None,
                        help='ideal torque gain R = z2/z1 [-] of every unit (a unit.yaml '
                             'may set its own)')
    parser.add_argument('--out', type=Path, required=True,
                        help='output directory (must not exist or be empty); written whole '
                             'or not at all')
    parser.add_argument('--scheduler', default=None, metavar='ADDRESS',
                        help='address of an existing Dask scheduler (tcp://host:8786); '
                             'default: a local cluster')
    parser.add_argument('--scheduler-timeout', type=float, default=CONNECT_TIMEOUT,
                        metavar='S',
                        help='seconds to wait for --scheduler to answer (default '
                             f'{CONNECT_TIMEOUT:g})')
    parser.add_argument('--workers', type=int, default=None,
                        help='local cluster: worker processes (default: one per core; at '
                             'most one per unit)')
    parser.add_argument('--param', action='append', default=[], metavar='NAME=VALUE',
                        help='estimator parameter for every unit (repeatable)')
    parser.add_argument('--no-unit-outputs', action='store_true',
                        help="write only the fleet table and plot, not each unit's bag")
    parser.add_argument('--population-prior', action='store_true',
                        help='units at end of life teach the others their wear law: analyse '
                             'the running units again with a prior on its shape (needs 3 '
                             'units at end of life with one exponential, power or '
                             'proportional law)')
    parser.add_argument('--no-plot', action='store_true', help='skip fleet.png')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')
    add_health_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from gear_phm.offline.fleet import FleetError, analyze_fleet
    if args.workers is not None and args.workers < 1:
        raise CliError(f'--workers must be >= 1, got {args.workers}')
    if not 0.0 < args.scheduler_timeout < math.inf:
        raise CliError(f'--scheduler-timeout must be > 0 s, got {args.scheduler_timeout}')
    options = {**estimator_params(args.param), **health_values(args)}
    try:
        results = analyze_fleet(args.root, args.out, ratio=args.ratio,
                                scheduler=args.scheduler, workers=args.workers,
                                progress=not args.no_progress,
                                unit_outputs=not args.no_unit_outputs,
                                population=args.population_prior,
                                timeout=args.scheduler_timeout, plot=not args.no_plot,
                                **options)
    except FleetError as exc:
        raise CliError(str(exc)) from None
    failed = [r.row for r in results if r.row['level'] == 'FAILED']
    for row in failed:
        print(f'unit {row["unit"]}: FAILED: {row["reason"]}', file=sys.stderr)
    print(f'{len(results)} units ({len(failed)} failed) -> {args.out}', file=sys.stderr)
    return 0
