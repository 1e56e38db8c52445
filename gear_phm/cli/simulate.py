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
from collections.abc import Callable, Sequence
from dataclasses import replace
import errno
import json
import math
from pathlib import Path
import shutil

import numpy as np

from gear_phm import stopping
from gear_phm.bagio import BagError, Rosbag2McapWriter
from gear_phm.bagio.batch_writer import vector3_stamped_rows
from gear_phm.cli.main import CliError
from gear_phm.cli.options import option_type
from gear_phm.codec import joint_state_rows
from gear_phm.interfaces import (drive_topic, JOINT_STATE_TYPE, JOINT_STATES, TRUTH_EFFICIENCY,
                                 TRUTH_FRICTION, VECTOR3_STAMPED_TYPE)
from gear_phm.parameters import LOAD_JOINT, MOTOR_JOINT, RATIO
from gear_phm.simulation import (config_from_parameters, PARAMETERS, REACHING_KINDS,
                                 SimulationConfig, SimulationResult, Simulator, Wear)
from gear_phm.simulation.lives import random_life
from gear_phm.staging import Staged
from gear_phm.transmissions import load_transmissions, TransmissionsError

HELP = 'simulate a wearing transmission into a rosbag2 MCAP directory (joint_states + truth)'
#: The default (motor, load) joint names.
JOINT_NAMES = (str(MOTOR_JOINT.default), str(LOAD_JOINT.default))

#: Samples simulated per chunk (bounds memory for long runs).
CHUNK = 20_000
#: Bytes written before the bag's final size is projected from them (:func:`write_drives`).
PROJECT_AFTER = 4 << 20
#: The random life's record, next to the bag's files in --out.
LIFE_FILE = 'life.json'
#: Default of --duration (the random life draws its own).
DURATION = 120.0
#: Every stamp is before this time [s since the epoch]: builtin_interfaces/Time's seconds are
#: an int32 (2**31 s: 03:14:08 UTC on 19 January 2038).
STAMP_LIMIT = float(2**31)
#: Highest --rate [Hz]: stamps are integer nanoseconds, a faster rate would repeat them.
RATE_LIMIT = 1e9
#: The fleet options' defaults: given without --fleet they would be ignored.
FLEET_DEFAULTS = {'recordings': 1, 'gap': 7 * 86400.0, 'gap_spread': 0.0, 'unit_spread': 0.2}


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
    parser.add_argument('--random-life', type=int, default=None, metavar='SEED',
                        help='draw a whole life from the documented prior (docs/lives.md): '
                             'plant, ratio, duty cycle, noise, wear law, onset, running-in, '
                             'stochastic wear, eta_opposing_min and a length of 300-30000 s; '
                             'writes life.json in --out and prints it. Takes --rate, '
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
        group.add_argument('--' + spec.name.replace('_', '-'), dest=spec.name,
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


_Drive = tuple[SimulationConfig, tuple[str, str], tuple[str, str]]


def _drive_configs(args: argparse.Namespace) -> list[_Drive]:
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
    configs = []
    for index, drive in enumerate(drives):
        values = drive.simulation_values(shared, index)
        try:
            config = config_from_parameters(values)
        except ValueError as exc:
            raise CliError(f'drive {drive.name}: {exc}') from None
        _check_jam(config, args.duration, f'drive {drive.name}: ')
        configs.append((config, (drive.motor_joint, drive.load_joint),
                        (drive_topic(drive.name, TRUTH_FRICTION),
                         drive_topic(drive.name, TRUTH_EFFICIENCY))))
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
    if not end < STAMP_LIMIT:
        raise CliError(f'{what} must end before {STAMP_LIMIT:.0f} s since the epoch (the int32 '
                       f'seconds of a ROS stamp end in 2038), got {end:.10g} s')


def _write_chunk(writer: Rosbag2McapWriter, results: Sequence[SimulationResult],
                 stamps_ns: np.ndarray, first_index: int, names: Sequence[str],
                 truth_every: int, truth_topics: Sequence[tuple[str, str]] = (
                     (TRUTH_FRICTION, TRUTH_EFFICIENCY),)) -> None:
    """Write one chunk of samples, packed as CDR rows at once.

    Per sample one JointState of every drive's joints (``names``: motor then load of each
    result), then (every ``truth_every``-th sample of the run) each drive's two truth
    Vector3Stamped (``truth_topics``, one pair per result): for one drive the order the
    message-by-message writer had.
    """
    joints = joint_state_rows(
        stamps_ns, names,
        np.column_stack([c for r in results for c in (r.position_motor, r.position_load)]),
        np.column_stack([c for r in results for c in (r.velocity_motor, r.velocity_load)]),
        np.column_stack([c for r in results for c in (r.effort_motor, r.effort_load)]))
    m, k = len(stamps_ns), truth_every
    head = min(m, -first_index % k)            # samples before the chunk's first truth sample
    truth = np.arange(head, m, k)
    zero = np.zeros(len(truth))
    truth_rows = []
    for result, (friction_topic, efficiency_topic) in zip(results, truth_topics):
        truth_rows.append((friction_topic, vector3_stamped_rows(stamps_ns[truth], np.column_stack(
            (result.u[truth], result.friction[truth], zero)))))
        truth_rows.append((efficiency_topic, vector3_stamped_rows(
            stamps_ns[truth], np.column_stack((result.eta_opposing[truth],
                                               result.eta_aiding[truth], zero)))))
    if head:                                   # one group: a run of joint states
        writer.write_groups([(JOINT_STATES, stamps_ns[None, :head], joints[None, :head])])
    periods = (m - head) // k                  # groups of k samples, the first with truth
    tail = head + periods * k
    for begin, end, n in ((head, tail, periods), (tail, m, 1)):
        if end > begin:
            js_stamps = stamps_ns[begin:end].reshape(n, -1)
            js = joints[begin:end].reshape(n, js_stamps.shape[1], -1)
            t = slice(len(truth) - n, len(truth)) if begin == tail else slice(0, n)
            writer.write_groups([(JOINT_STATES, js_stamps[:, :1], js[:, :1]),
                                 *[(topic, stamps_ns[truth[t]], rows[t])
                                   for topic, rows in truth_rows],
                                 (JOINT_STATES, js_stamps[:, 1:], js[:, 1:])])


def write_simulation(out: Path, config: SimulationConfig, duration: float, rate: float,
                     start_time: float = 0.0, names: tuple[str, str] = JOINT_NAMES,
                     truth_every: int = 1, compression: str | None = 'zstd',
                     operating_offset: float = 0.0) -> int:
    """Simulate ``duration`` [s] at ``rate`` [Hz] into the rosbag2 directory ``out``.

    The plant's clock (wear, duty cycle) starts at ``operating_offset`` [s]: a recording
    that continues a life after idle time. Returns the number of samples. Deterministic: no
    wall-clock flushes, fixed stamps.
    """
    return write_drives(out, [(config, names, (TRUTH_FRICTION, TRUTH_EFFICIENCY))], duration,
                        rate, start_time, truth_every, compression, operating_offset)


def write_drives(out: Path, drives: Sequence[_Drive],
                 duration: float, rate: float, start_time: float = 0.0, truth_every: int = 1,
                 compression: str | None = 'zstd', operating_offset: float = 0.0) -> int:
    """Simulate drives in one JointState stream into the rosbag2 directory ``out``.

    ``drives``: per drive its configuration, its (motor, load) joint names and its (friction,
    efficiency) truth topics. Each drive has its own simulator; all share the stamps. Returns
    the number of samples (JointState messages); see :func:`write_simulation`.

    Raises OSError (ENOSPC) as soon as the bag's size, projected from what has been written,
    exceeds the free space of ``out``'s file system: a long run is refused in its first
    megabytes, not when the disk is full.
    """
    count = int(math.floor(duration * rate + 1e-9))
    start_ns = int(round(start_time * 1e9))
    simulators = [Simulator(config) for config, _, _ in drives]
    names = [name for _, pair, _ in drives for name in pair]
    truth_topics = [topics for _, _, topics in drives]
    with Rosbag2McapWriter(out, compression=compression, flush_period_s=None,
                           batch=True) as writer:
        writer.add_topic(JOINT_STATES, JOINT_STATE_TYPE)
        for topic in (topic for pair in truth_topics for topic in pair):
            writer.add_topic(topic, VECTOR3_STAMPED_TYPE)
        for first in range(0, count, CHUNK):
            stopping.check()            # a signal's stop that was swallowed
            index = np.arange(first, min(first + CHUNK, count))
            # integer-nanosecond stamps, no accumulated rounding: stamp_k = start + k/rate
            stamps_ns = start_ns + np.round(index * (1e9 / rate)).astype(np.int64)
            times = operating_offset + (stamps_ns - start_ns) * 1e-9
            with np.errstate(over='ignore', invalid='ignore'):  # refused by _check_finite
                results = [simulator.sample(times) for simulator in simulators]
            for (_, joints, _), result in zip(drives, results):
                _check_finite(result, joints if len(drives) > 1 else None)
            _write_chunk(writer, results, stamps_ns, first, names, truth_every, truth_topics)
            _check_space(out, first + index.size, count)
    return count


#: The fields of a SimulationResult that are written.
WRITTEN = ('position_motor', 'position_load', 'velocity_motor', 'velocity_load', 'effort_motor',
           'effort_load', 'u', 'friction', 'eta_opposing', 'eta_aiding')


def _check_finite(result: SimulationResult, joints: tuple[str, str] | None) -> None:
    """Raise ValueError if a value to be written is NaN or infinite (``joints``: the drive's)."""
    for name in WRITTEN:
        values = getattr(result, name)
        bad = ~np.isfinite(values)
        if bad.any():
            first = int(np.argmax(bad))
            where = f'drive {joints[0]}/{joints[1]}: ' if joints else ''
            msg = (f'{where}the simulation gave {name} = {float(values[first])!r} at t = '
                   f'{float(result.t[first]):g} s: the parameters are beyond what float64 '
                   f'holds; use physical values')
            raise ValueError(msg)


def _check_space(out: Path, done: int, count: int) -> None:
    """Raise OSError (ENOSPC) if ``count`` samples will not fit on ``out``'s file system.

    Projected from the ``done`` samples that ``out`` holds now, once they take
    :data:`PROJECT_AFTER` bytes or more.
    """
    written = sum(path.stat().st_size for path in out.iterdir() if path.is_file())
    if written < PROJECT_AFTER or done >= count:
        return
    projected = written * count / done
    free = shutil.disk_usage(out).free
    if projected - written > free:
        msg = (f'{count:,} samples would take about {projected / 1e9:.3g} GB; '
               f'{free / 1e9:.3g} GB are free')
        raise OSError(errno.ENOSPC, msg)


def write_fleet(out: Path, config: SimulationConfig, args: argparse.Namespace) -> int:
    """Write units ``unit_00``... with ``--recordings`` bags each and ``truth.yaml``.

    Returns the number of samples written.
    """
    import yaml
    rng = np.random.default_rng(config.seed)
    gap_rng = np.random.default_rng([config.seed, 1])     # leaves the units' draws unchanged
    total = 0
    for unit in range(args.fleet):
        spread = args.unit_spread
        # an overflow to inf is refused below (Wear, _check_end), with the option to blame
        with np.errstate(over='ignore'):
            initial = float(config.wear.initial * np.exp(spread * rng.standard_normal()))
            rate = float(config.wear.rate * np.exp(spread * rng.standard_normal()))
            gaps = args.gap * np.exp(args.gap_spread * gap_rng.standard_normal(args.recordings))
            starts = [args.start_time + k * args.duration + float(np.sum(gaps[:k]))
                      if args.gap_spread else args.start_time + k * (args.duration + args.gap)
                      for k in range(args.recordings)]
        try:
            wear = replace(config.wear, initial=initial, rate=rate)
        except ValueError as exc:
            raise CliError(f'unit {unit}: --unit-spread {spread:g} drew an unusable wear '
                           f'({exc}); lower --unit-spread') from None
        _check_end(starts[-1] + args.duration,
                   f'unit {unit}: --start-time + --recordings x --duration + the gaps')
        unit_config = replace(config, wear=wear)
        folder = out / f'unit_{unit:02d}'
        for k, start in enumerate(starts):
            # the unit's stochastic wear path runs on across its recordings
            recording = replace(unit_config, seed=config.seed * 10_000 + unit * 100 + k,
                                wear_seed=config.seed * 10_000 + unit * 100)
            total += write_simulation(
                folder / f'rec_{k:03d}', recording, args.duration, args.rate, start,
                (args.motor_joint, args.load_joint), args.truth_every,
                None if args.compression == 'none' else args.compression,
                operating_offset=k * args.duration)
        truth = {'ratio': config.plant.ratio, 'plant': config.plant.efficiency_model,
                 'wear': {'kind': wear.kind, 'initial': initial, 'rate': rate,
                          't_fault': wear.t_fault, 'step': wear.step,
                          'exponent': wear.exponent},
                 'recording_duration_s': args.duration, 'gap_s': args.gap,
                 'gap_spread': args.gap_spread,
                 'recording_start_s': starts, 'rate_hz': args.rate, 'seed': config.seed,
                 'note': 'wear advances with operating time only: the friction value of the '
                         'plant at operating time s is wear(s); recording k covers '
                         'operating time [k d, (k + 1) d), d = recording_duration_s'}
        (folder / 'truth.yaml').write_text(yaml.safe_dump(truth, sort_keys=False))
    return total


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
        life = random_life(args.random_life, args.rate)
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
        count = _writing(out, lambda target: write_fleet(target, config, args))
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
