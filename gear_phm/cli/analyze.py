"""``gear-phm analyze BAG (--ratio R | --transmissions FILE) --out DIR``: ``analyze_bag``'s CLI.

:func:`gear_phm.offline.analyze_bag` runs the estimator and diagnostics nodes' code over a
recorded bag.

Writes DIR as a rosbag2 MCAP directory with the nodes' topics (and their /diagnostics status
every second of bag time), stamped in bag time, plus DIR/summary.json and DIR/analysis.png.

The result goes to stdout, one line per drive: the final estimate and the health level with
its cause and, for WARN and ERROR, when it was first reported (bag time since the first bag's
start), e.g. ``u = 0.30050 +/- 0.00151, eta_D = 0.6918, eta_I = 0.6359; level ERROR (end of
life, at 276 s)``. How long it took goes to stderr.
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
import re
import sys
from typing import Any, TYPE_CHECKING

from gear_phm import interfaces
from gear_phm.cli.main import CliError
from gear_phm.cli.options import add_health_arguments, estimator_params, health_values
from gear_phm.parameters import (DIAGNOSTICS_RATE, HARDWARE_ID, LOAD_JOINT, MOTOR_JOINT,
                                 STAMP_SOURCE, TRANSMISSION_NAME)

if TYPE_CHECKING:
    from gear_phm.offline.summary import HealthSummary

HELP = 'estimate friction offline from a recorded bag (same code as the estimator node)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', nargs='+',
                        help='rosbag2 directory, .mcap, .db3 or ROS1 .bag, or a folder of '
                             'them; several are analysed as one run, in order of their start '
                             'times')
    parser.add_argument('--ratio', type=float, default=None,
                        help='ideal torque gain load/motor R = z2/z1 [-] (one transmission)')
    parser.add_argument('--transmissions', default=None, metavar='FILE.yaml',
                        help='many drives in one JointState stream, instead of --ratio and '
                             'the joints: a transmissions file or node parameters file '
                             '(README "Bench"); the options below apply to each drive that '
                             'does not set its own')
    parser.add_argument('--motor-joint', default=MOTOR_JOINT.default,
                        help=f'motor joint name (default {MOTOR_JOINT.default})')
    parser.add_argument('--load-joint', default=LOAD_JOINT.default,
                        help=f'load joint name (default {LOAD_JOINT.default})')
    parser.add_argument('--topic', default=interfaces.JOINT_STATES,
                        help='JointState topic (default joint_states)')
    parser.add_argument('--out', required=True, help='output directory (must not exist)')
    parser.add_argument('--param', action='append', default=[], metavar='NAME=VALUE',
                        help='estimator parameter, as in config/estimator.yaml (repeatable)')
    parser.add_argument('--transmission-name', default=TRANSMISSION_NAME.default,
                        help='diagnostics status name "gear_phm: <name>" (default '
                             f'{TRANSMISSION_NAME.default})')
    parser.add_argument('--hardware-id', default=HARDWARE_ID.default,
                        help=f'diagnostics hardware_id (default {HARDWARE_ID.default})')
    parser.add_argument('--diagnostics-rate', type=float, default=DIAGNOSTICS_RATE.default,
                        metavar='HZ', help='/diagnostics rate in bag time [Hz], as the nodes '
                                           f'(default {DIAGNOSTICS_RATE.default})')
    parser.add_argument('--stamp-source', choices=STAMP_SOURCE.choices,
                        default=STAMP_SOURCE.default,
                        help=f'{STAMP_SOURCE.description} (default {STAMP_SOURCE.default})')
    parser.add_argument('--overwrite', action='store_true',
                        help='replace --out if it holds a previous analysis and nothing else '
                             '(summary.json, its bag, plots); never a bag being analysed')
    parser.add_argument('--no-plot', action='store_true', help='skip the PNG')
    parser.add_argument('--jobs', type=int, default=0, metavar='N',
                        help='worker processes: with --transmissions, for the drives (at '
                             'most one per drive), while this one reads, decodes and writes '
                             "(the bag is still read once); one drive's health assessment in "
                             'one, beside its estimator; 0 (default): one per core, for bags '
                             'of 100,000 samples or more (messages times drives); 1: all in '
                             'this process. The results do not depend on it')
    add_health_arguments(parser)
    parser.add_argument('--no-progress', action='store_true',
                        help='no progress bar (there is one only when stderr is a terminal)')


def run(args: argparse.Namespace) -> int:
    from gear_phm.estimation.pipeline import NOT_IDENTIFIABLE
    from gear_phm.offline import AnalysisError, analyze_bag, AnalyzeOptions
    from gear_phm.offline.parallel import ParallelError
    from gear_phm.offline.summary import DriveSummary

    if (args.ratio is None) == (args.transmissions is None):
        raise CliError('give --ratio (one transmission) or --transmissions FILE (many drives)')
    if args.jobs < 0:
        raise CliError(f'--jobs must be 0 (one per core) or more, got {args.jobs}')
    options: dict[str, Any] = {**estimator_params(args.param), **health_values(args)}
    if args.transmissions is not None:
        options['transmissions'] = args.transmissions
        for name, default in (('motor_joint', MOTOR_JOINT.default),
                              ('load_joint', LOAD_JOINT.default),
                              ('transmission_name', TRANSMISSION_NAME.default),
                              ('hardware_id', HARDWARE_ID.default)):
            if getattr(args, name) != default:
                raise CliError(f'--{name.replace("_", "-")}: with --transmissions each drive '
                               f'has its own (the file)')
    else:
        options.update(ratio=args.ratio, motor_joint=args.motor_joint,
                       load_joint=args.load_joint, transmission_name=args.transmission_name,
                       hardware_id=args.hardware_id)
    try:
        analysis = analyze_bag(args.bag, AnalyzeOptions.of(
            topic=args.topic, out=args.out, overwrite=args.overwrite,
            plot=not args.no_plot, progress=not args.no_progress and sys.stderr.isatty(),
            diagnostics_rate=args.diagnostics_rate, stamp_source=args.stamp_source,
            jobs=args.jobs, **options))
    except (AnalysisError, ParallelError) as exc:
        raise CliError(str(exc)) from None
    summary = analysis.summary
    start_ns = bags_start_ns(args.bag)
    run = summary.run
    rate = (f'{run.messages} messages in {run.seconds:.2f} s '
            f'({run.samples_per_second:.0f}/s) -> {analysis.out}')
    drives = ({'': summary} if isinstance(summary, DriveSummary)
              else dict(summary.transmissions))
    for name, drive in drives.items():
        if drive.no_measurement is not None:        # a drive of many that did not move
            print(f'{name}: no efficiency measurement ({drive.no_measurement})',
                  file=sys.stderr)
            continue
        e = drive.estimator
        level = health_line(drive.health, start_ns)
        if e.held:                                  # the no-load model held every window
            print(f'{name + ": " if name else ""}{NOT_IDENTIFIABLE} at its prior '
                  f"({e.counts['not_identifiable']} windows held); {level}")
            continue
        print(f'{name + ": " if name else ""}u = {e.u:.5f} +/- {e.sigma_u:.5f}, '
              f'eta_D = {e.eta_opposing:.4f}, eta_I = {e.eta_aiding:.4f}; {level}')
    print(rate, file=sys.stderr)
    return 0


def health_line(health: HealthSummary, start_ns: int | None) -> str:
    """Return ``level ERROR (end of life, at 276 s)``: the level, its cause, when first seen.

    The cause is the status message up to its details (the first ``' ('``, ``': '`` or
    ``'; '``); the time, for WARN and ERROR, is since ``start_ns`` (omitted when None).
    """
    cause = re.split(r' \(|: |; ', health.message or '', maxsplit=1)[0] or 'no health state'
    first = health.first_seen_ns.get(health.level)
    if health.level in ('WARN', 'ERROR') and first is not None and start_ns is not None:
        cause += f', at {(first - start_ns) * 1e-9:.0f} s'
    if cause.lower() == health.level.lower():         # 'ok'
        return f'level {health.level}'
    return f'level {health.level} ({cause})'


def bags_start_ns(paths: Sequence[str]) -> int | None:
    """Return the earliest start [ns] the bags' metadata.yaml give (None: none readable)."""
    import yaml
    starts = []
    for path in paths:
        try:
            text = (Path(path) / 'metadata.yaml').read_text(encoding='utf-8')
            info = yaml.safe_load(text)['rosbag2_bagfile_information']
            starts.append(int(info['starting_time']['nanoseconds_since_epoch']))
        except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError, ValueError):
            continue
    return min(starts, default=None)
