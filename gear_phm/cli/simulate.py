"""``gear-phm simulate --out DIR``: simulate a wearing transmission into a rosbag2 MCAP bag.

``--random-life SEED`` draws the whole life (plant, duty cycle, noise, wear law, onset,
end-of-life threshold, record length) from the prior of :mod:`gear_phm.simulation.lives`
(docs/lives.md), writes the bag and ``life.json`` (what was drawn and the true end of life)
in ``--out``, and prints that JSON.

``--transmissions FILE`` simulates many drives in one stream (:mod:`gear_phm.transmissions`):
one JointState with every drive's joints per sample, each drive's truth on
``/gear_phm/<drive>/truth/...``.

Topics: ``/joint_states`` (sensor_msgs/JointState, joints ``motor`` and ``load``),
``/gear_phm/truth/friction`` and ``/gear_phm/truth/efficiency`` (geometry_msgs/Vector3Stamped,
layouts in docs/architecture.md). Stamps and log times are ``start_time + k / rate``, so the
simulation time of a message is ``stamp - start_time``. The output is byte-for-byte the same
for the same arguments (no wall-clock time is written; see docs/publisher.md).
"""
from __future__ import annotations

import argparse
from collections.abc import Callable
import json
import math
from pathlib import Path

import numpy as np

from gear_phm.bagio import BagError
from gear_phm.cli.main import CliError
from gear_phm.cli.options import option_type
from gear_phm.parameters import LOAD_JOINT, MOTOR_JOINT, RATIO
from gear_phm.simulation import (config_from_parameters, PARAMETERS, REACHING_KINDS,
                                 SimulationConfig, Wear)
from gear_phm.simulation.lives import LIFE_FILE, PRIORS, random_life
from gear_phm.simulation.recording import (check_end, Drive, Fleet, STAMP_LIMIT, write_drives,
                                           write_fleet, write_simulation)
from gear_phm.staging import Staged
from gear_phm.transmissions import load_transmissions, TransmissionsError

HELP = 'simulate a wearing transmission into a rosbag2 MCAP directory (joint_states + truth)'
#: Default of --duration (the random life draws its own).
DURATION = 120.0
#: Highest --rate [Hz]: stamps are integer nanoseconds, a faster rate would repeat them.
RATE_LIMIT = 1e9
#: The fleet options' defaults: given without --fleet they would be ignored.
FLEET_DEFAULTS = {name: getattr(Fleet(1), name)
                  for name in ('recordings', 'gap', 'gap_spread', 'unit_spread')}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', type=Path, required=True,
                        help='output rosbag2 directory (must not exist or be empty)')
    parser.add_argument('--duration', type=float, default=DURATION,
                        help=f'length [s] ({DURATION:g})')
    parser.add_argument('--rate', type=float, default=100.0, help='sample rate [Hz] (100)')
    parser.add_argument('--start-time', type=float, default=0.0,
                        help='stamp of the first sample [s since epoch] (0)')
    for spec in (MOTOR_JOINT, LOAD_JOINT):
        parser.add_argument('--' + spec.name.replace('_', '-'), default=spec.default,
                            help=f'{spec.description} ({spec.default})')
    parser.add_argument('--friction-final', type=float, default=None,
                        help='linear/exponential/power wear: friction value reached at the '
                             'end of the run (sets --wear-rate)')
    parser.add_argument('--truth-every', type=int, default=1,
                        help='write the truth topics every N-th sample (1)')
    parser.add_argument('--compression', choices=('zstd', 'lz4', 'none'), default='zstd',
                        help='MCAP chunk compression (zstd)')
    parser.add_argument('--transmissions', type=Path, default=None, metavar='FILE.yaml',
                        help='many drives in one JointState stream (README "Bench"): each '
                             'drive of the file with its joints, ratio and simulation keys; '
                             'the simulation options below apply to each drive that does not '
                             "set its own (seed: --seed + the drive's index). Truth on "
                             'gear_phm/<drive>/truth/...')
    parser.add_argument('--prior', choices=PRIORS, default=PRIORS[0],
                        help="the prior of --random-life: paper (the paper's physics), "
                             'bench (every real-gearbox effect on: no-load drag and oil '
                             'warming, varying loads, sensor errors, encoders, cold restarts) '
                             "or architectures (the paper's physics on a gear train, "
                             'planetary, worm or screw plant); docs/lives.md (paper)')
    parser.add_argument('--random-life', type=int, default=None, metavar='SEED',
                        help='draw a whole life from the documented prior (docs/lives.md): '
                             'plant, ratio, duty cycle, noise, wear law, onset, running-in, '
                             'stochastic wear, eta_opposing_min and a length of 300-30000 s; '
                             'writes life.json in --out and prints it. Takes --prior, --rate, '
                             '--start-time, joint names, --truth-every, --compression only')
    fleet = parser.add_argument_group(
        'fleet: --out becomes a tree of unit folders, each with --recordings bags of '
        '--duration seconds of operation separated by --gap seconds of idle time')
    fleet.add_argument('--fleet', type=int, default=0, metavar='N',
                       help='simulate N units instead of one bag (0)')
    fleet.add_argument('--recordings', type=int, default=1, metavar='M',
                       help='recordings per unit (1)')
    fleet.add_argument('--gap', type=float, default=FLEET_DEFAULTS['gap'],
                       help='idle time between recordings [s] (one week)')
    fleet.add_argument('--gap-spread', type=float, default=0.0,
                       help='each gap is --gap times a log-normal factor of this spread, '
                            'e.g. 1.0 for irregular flights (0: every gap equal)')
    fleet.add_argument('--unit-spread', type=float, default=0.2,
                       help='unit-to-unit relative spread of --friction-initial and '
                            '--wear-rate (0.2)')
    group = parser.add_argument_group("simulation parameters (as the publisher node's)")
    for spec in PARAMETERS:
        option = '--' + spec.name.replace('_', '-')
        if spec.kind is bool:
            group.add_argument(option, dest=spec.name, action='store_true',
                               help=spec.description)
            continue
        group.add_argument(option, dest=spec.name,
                           type=option_type(spec) if spec.kind is not str else str,
                           default=spec.default, help=f'{spec.text} ({spec.default})')


def _config(args: argparse.Namespace) -> SimulationConfig:
    values = {spec.name: getattr(args, spec.name) for spec in PARAMETERS}
    if args.friction_final is not None:
        if args.wear not in REACHING_KINDS:
            raise CliError(f'--friction-final needs --wear linear, exponential or power, '
                           f'got --wear {args.wear}')
        try:
            wear = Wear.reaching(args.wear, args.friction_initial, args.friction_final,
                                 args.duration, args.wear_exponent)
        except ValueError as exc:
            raise CliError(str(exc)) from None
        values['wear_rate'] = wear.rate
    try:
        config = config_from_parameters(values)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    _check_jam(config, args.duration)
    return config


def _drive_configs(args: argparse.Namespace) -> list[Drive]:
    """Return each drive of ``--transmissions`` as write_drives' (config, joints, truth)."""
    given = [option for option, value, default in (
        ('--random-life', args.random_life, None), ('--fleet', args.fleet, 0),
        ('--friction-final', args.friction_final, None),
        ('--motor-joint', args.motor_joint, MOTOR_JOINT.default),
        ('--load-joint', args.load_joint, LOAD_JOINT.default),
        ('--ratio', args.ratio, RATIO.default)) if value != default]
    if given:
        raise CliError(f'--transmissions sets each drive: drop {", ".join(given)}')
    try:
        drives = load_transmissions(args.transmissions)
    except TransmissionsError as exc:
        raise CliError(str(exc)) from None
    shared = {spec.name: getattr(args, spec.name) for spec in PARAMETERS}
    configs: list[Drive] = []
    for index, drive in enumerate(drives):
        values = drive.simulation_values(shared, index)
        try:
            config = config_from_parameters(values)
        except ValueError as exc:
            raise CliError(f'drive {drive.name}: {exc}') from None
        _check_jam(config, args.duration, f'drive {drive.name}: ')
        configs.append((config, (drive.motor_joint, drive.load_joint), drive.name))
    return configs


def _check_jam(config: SimulationConfig, duration: float, what: str = '') -> None:
    """Refuse a wear that jams the gearbox (eta_D <= 0) within ``duration`` [s]."""
    # wear never decreases: the friction at the end is the largest of the run
    with np.errstate(over='ignore', invalid='ignore'):
        friction_end = float(config.wear.value(duration))
    if not math.isfinite(friction_end):
        raise CliError(f'{what}the wear law gives a friction value of {friction_end} at '
                       f'--duration {duration:g} s (beyond float64); lower the wear')
    _, eta_d, _ = config.plant.efficiencies(friction_end)
    if not float(eta_d) > 0.0:
        raise CliError(f'{what}friction value {friction_end:.4g} reached at --duration '
                       f'{duration:g} s gives eta_D = {float(eta_d):.4g} <= 0 '
                       f'(the gearbox jams); lower the wear')


def _check(args: argparse.Namespace) -> None:
    if not (math.isfinite(args.rate) and args.rate > 0):
        raise CliError(f'--rate must be > 0 Hz, got {args.rate!r}')
    if args.rate > RATE_LIMIT:
        raise CliError(f'--rate must be <= {RATE_LIMIT:g} Hz (stamps are integer nanoseconds), '
                       f'got {args.rate!r}')
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise CliError(f'--duration must be > 0 s, got {args.duration!r}')
    if not (math.isfinite(args.start_time) and 0 <= args.start_time < STAMP_LIMIT):
        raise CliError(f'--start-time must be >= 0 and < {STAMP_LIMIT:.0f} s since the epoch '
                       f'(the int32 seconds of a ROS stamp end in 2038), got {args.start_time!r}')
    if args.truth_every < 1:
        raise CliError(f'--truth-every must be >= 1, got {args.truth_every!r}')
    if args.motor_joint == args.load_joint or not args.motor_joint or not args.load_joint:
        raise CliError(f'--motor-joint and --load-joint must be two different non-empty names, '
                       f'got {args.motor_joint!r} and {args.load_joint!r}')
    if not args.fleet:
        given = [f'--{name.replace("_", "-")}' for name, default in FLEET_DEFAULTS.items()
                 if getattr(args, name) != default]
        if given:
            raise CliError(f'{", ".join(given)}: for a fleet only (add --fleet N or drop '
                           f'them)')
    elif args.fleet < 1 or args.recordings < 1:
        raise CliError(f'--fleet and --recordings must be >= 1, got {args.fleet} and '
                       f'{args.recordings}')
    elif not (math.isfinite(args.gap) and args.gap >= 0):
        raise CliError(f'--gap must be >= 0 s, got {args.gap!r}')
    elif not (math.isfinite(args.gap_spread) and args.gap_spread >= 0):
        raise CliError(f'--gap-spread must be >= 0, got {args.gap_spread!r}')
    elif not (math.isfinite(args.unit_spread) and args.unit_spread >= 0):
        raise CliError(f'--unit-spread must be >= 0, got {args.unit_spread!r}')
    if args.random_life is None and args.prior != PRIORS[0]:
        raise CliError(f'--prior {args.prior}: for --random-life only')
    if args.random_life is None:
        if not args.fleet:
            _check_end(args.start_time + args.duration, '--start-time + --duration')
        else:
            recordings = float(args.recordings) if args.recordings < 10**300 else math.inf
            gaps = 0.0 if args.gap_spread else (recordings - 1) * args.gap
            _check_end(args.start_time + recordings * args.duration + gaps,
                       '--start-time + --recordings x --duration + the gaps')
        _check_count(args.duration, args.rate, f'--duration {args.duration:g} s')


def _check_count(duration: float, rate: float, what: str) -> None:
    """Refuse a run of ``duration`` [s] at ``rate`` [Hz] that has no sample."""
    if math.floor(duration * rate + 1e-9) < 1:
        raise CliError(f'{what} at --rate {rate:g} Hz gives no sample (duration x rate < 1): '
                       f'a bag needs at least one')


def _check_end(end: float, what: str) -> None:
    """Refuse a run whose end, ``what`` [s since the epoch], is not before STAMP_LIMIT."""
    try:
        check_end(end, what)
    except ValueError as exc:
        raise CliError(str(exc)) from None


def _write_random_life(out: Path, args: argparse.Namespace) -> int:
    """Draw life ``--random-life``, write its bag and life.json into ``out``, print the JSON."""
    given = [f'--{name.replace("_", "-")}' for name, default in
             [(spec.name, spec.default) for spec in PARAMETERS]
             + [('duration', DURATION), ('friction_final', None), ('fleet', 0)]
             if getattr(args, name) != default]
    if given:
        raise CliError(f'--random-life draws every simulation parameter; drop '
                       f'{", ".join(given)}')
    if args.random_life < 0:
        raise CliError(f'--random-life must be an integer >= 0, got {args.random_life}')
    try:
        life = random_life(args.random_life, args.rate, args.prior)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    _check_end(args.start_time + life.duration,
               f'--start-time + the drawn duration {life.duration:g} s')
    text = json.dumps(life.to_json(), indent=2)

    def write(target: Path) -> int:
        count = write_simulation(target, life.config(), life.duration, args.rate,
                                 args.start_time, (args.motor_joint, args.load_joint),
                                 args.truth_every,
                                 None if args.compression == 'none' else args.compression)
        (target / LIFE_FILE).write_text(text + '\n', encoding='utf-8')
        return count
    _writing(out, write)
    print(text)
    return 0


def _writing(out: Path, write: Callable[[Path], int]) -> int:
    """Return what ``write`` returns, written whole into ``out`` or not at all.

    ``write`` gets a directory in a hidden staging folder beside ``out``
    (:class:`~gear_phm.staging.Staged`), which becomes ``out`` once it is complete; on any
    error (and on Ctrl-C) the staging folder is removed, so no half-written bag is left.
    Errors as CliError; ValueError: e.g. the wear trajectory jams the gearbox within the run.
    """
    try:
        with Staged(out, CliError) as staged:
            result = write(staged.path)
            staged.commit()
            return result
    except ValueError as exc:
        raise CliError(str(exc)) from None
    except (OSError, BagError) as exc:
        raise CliError(f'cannot write {out}: {exc}') from None


def run(args: argparse.Namespace) -> int:
    _check(args)
    out: Path = args.out
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise CliError(f'--out {out} exists and is not an empty directory')
    if args.transmissions is not None:
        drives = _drive_configs(args)
        count = _writing(out, lambda target: write_drives(
            target, drives, args.duration, args.rate, args.start_time, args.truth_every,
            None if args.compression == 'none' else args.compression))
        print(f'wrote {count} samples of {len(drives)} drives ({args.duration:g} s at '
              f'{args.rate:g} Hz) to {out}')
        return 0
    if args.random_life is not None:
        return _write_random_life(out, args)
    if args.fleet:
        # the life spans all recordings: --friction-final is reached at the last one's end
        args.duration, single = args.duration * args.recordings, args.duration
        config = _config(args)
        args.duration = single
        fleet = Fleet(args.fleet, args.recordings, args.gap, args.gap_spread, args.unit_spread)
        count = _writing(out, lambda target: write_fleet(
            target, config, fleet, args.duration, args.rate, args.start_time,
            (args.motor_joint, args.load_joint), args.truth_every,
            None if args.compression == 'none' else args.compression))
        print(f'wrote {args.fleet} units x {args.recordings} recordings, {count} samples, '
              f'to {out}')
        return 0
    config = _config(args)
    count = _writing(out, lambda target: write_simulation(
        target, config, args.duration, args.rate, args.start_time,
        (args.motor_joint, args.load_joint), args.truth_every,
        None if args.compression == 'none' else args.compression))
    print(f'wrote {count} samples ({args.duration:g} s at {args.rate:g} Hz) to {out}')
    return 0
