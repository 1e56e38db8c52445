"""``gear-phm simulate --out DIR``: simulate a wearing transmission into a rosbag2 MCAP bag.

Topics: ``/joint_states`` (sensor_msgs/JointState, joints ``motor`` and ``load``),
``/gear_phm/truth/friction`` and ``/gear_phm/truth/efficiency`` (geometry_msgs/Vector3Stamped,
layouts in docs/architecture.md). Stamps and log times are ``start_time + k / rate``, so the
simulation time of a message is ``stamp - start_time``. The output is byte-for-byte the same
for the same arguments (no wall-clock time is written; see docs/publisher.md).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from gear_phm.bagio import BagError, Rosbag2McapWriter, TYPESTORE
from gear_phm.cli.main import CliError
from gear_phm.interfaces import (JOINT_STATE_TYPE, JOINT_STATES, ns_to_sec_nanosec,
                                 TRUTH_EFFICIENCY, TRUTH_FRICTION, VECTOR3_STAMPED_TYPE)
from gear_phm.simulation import (config_from_parameters, PARAMETERS, SimulationConfig,
                                 SimulationResult, Simulator, Wear)

HELP = 'simulate a wearing transmission into a rosbag2 MCAP directory (joint_states + truth)'

#: Samples simulated per chunk (bounds memory for long runs).
CHUNK = 20_000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--out', type=Path, required=True,
                        help='output rosbag2 directory (must not exist or be empty)')
    parser.add_argument('--duration', type=float, default=120.0, help='length [s] (120)')
    parser.add_argument('--rate', type=float, default=100.0, help='sample rate [Hz] (100)')
    parser.add_argument('--start-time', type=float, default=0.0,
                        help='stamp of the first sample [s since epoch] (0)')
    parser.add_argument('--motor-joint', default='motor', help='motor joint name (motor)')
    parser.add_argument('--load-joint', default='load', help='load joint name (load)')
    parser.add_argument('--friction-final', type=float, default=None,
                        help='linear/exponential wear: friction value reached at the end of '
                             'the run (sets --wear-rate)')
    parser.add_argument('--truth-every', type=int, default=1,
                        help='write the truth topics every N-th sample (1)')
    parser.add_argument('--compression', choices=('zstd', 'lz4', 'none'), default='zstd',
                        help='MCAP chunk compression (zstd)')
    group = parser.add_argument_group("simulation parameters (as the publisher node's)")
    for name, (default, description, _, _) in PARAMETERS.items():
        kind = type(default)
        group.add_argument('--' + name.replace('_', '-'), dest=name, type=kind,
                           default=default, help=f'{description} ({default})')


def _config(args: argparse.Namespace) -> SimulationConfig:
    values = {name: getattr(args, name) for name in PARAMETERS}
    if args.friction_final is not None:
        if args.wear not in ('linear', 'exponential'):
            raise CliError(f'--friction-final needs --wear linear or exponential, '
                           f'got --wear {args.wear}')
        try:
            wear = Wear.reaching(args.wear, args.friction_initial, args.friction_final,
                                 args.duration)
        except ValueError as exc:
            raise CliError(str(exc)) from None
        values['wear_rate'] = wear.rate
    try:
        config = config_from_parameters(values)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    # wear never decreases: the friction at the end is the largest of the run
    friction_end = float(config.wear.value(args.duration))
    _, eta_d, _ = config.plant.efficiencies(friction_end)
    if not float(eta_d) > 0.0:
        raise CliError(f'friction value {friction_end:.4g} reached at --duration '
                       f'{args.duration:g} s gives eta_D = {float(eta_d):.4g} <= 0 '
                       f'(the gearbox jams); lower the wear')
    return config


def _check(args: argparse.Namespace) -> None:
    if not (math.isfinite(args.rate) and args.rate > 0):
        raise CliError(f'--rate must be > 0 Hz, got {args.rate!r}')
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise CliError(f'--duration must be > 0 s, got {args.duration!r}')
    if not (math.isfinite(args.start_time) and args.start_time >= 0):
        raise CliError(f'--start-time must be >= 0 s, got {args.start_time!r}')
    if args.truth_every < 1:
        raise CliError(f'--truth-every must be >= 1, got {args.truth_every!r}')
    if args.motor_joint == args.load_joint or not args.motor_joint or not args.load_joint:
        raise CliError(f'--motor-joint and --load-joint must be two different non-empty names, '
                       f'got {args.motor_joint!r} and {args.load_joint!r}')


def _header(stamp_ns: int) -> Any:
    sec, nanosec = ns_to_sec_nanosec(stamp_ns)
    return TYPESTORE.types['std_msgs/msg/Header'](
        stamp=TYPESTORE.types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec),
        frame_id='')


def _write_chunk(writer: Rosbag2McapWriter, result: SimulationResult, stamps_ns: np.ndarray,
                 first_index: int, names: list[str], truth_every: int) -> None:
    joint_state = TYPESTORE.types[JOINT_STATE_TYPE]
    vector3_stamped = TYPESTORE.types[VECTOR3_STAMPED_TYPE]
    vector3 = TYPESTORE.types['geometry_msgs/msg/Vector3']
    position = np.column_stack((result.position_motor, result.position_load))
    velocity = np.column_stack((result.velocity_motor, result.velocity_load))
    effort = np.column_stack((result.effort_motor, result.effort_load))
    for i, t_ns in enumerate(stamps_ns.tolist()):
        header = _header(t_ns)
        writer.write(JOINT_STATES, t_ns, joint_state(
            header=header, name=names, position=position[i].copy(),
            velocity=velocity[i].copy(), effort=effort[i].copy()))
        if (first_index + i) % truth_every == 0:
            writer.write(TRUTH_FRICTION, t_ns, vector3_stamped(header=header, vector=vector3(
                x=float(result.u[i]), y=float(result.friction[i]), z=0.0)))
            writer.write(TRUTH_EFFICIENCY, t_ns, vector3_stamped(header=header, vector=vector3(
                x=float(result.eta_opposing[i]), y=float(result.eta_aiding[i]), z=0.0)))


def write_simulation(out: Path, config: SimulationConfig, duration: float, rate: float,
                     start_time: float = 0.0, names: tuple[str, str] = ('motor', 'load'),
                     truth_every: int = 1, compression: str | None = 'zstd') -> int:
    """Simulate ``duration`` [s] at ``rate`` [Hz] into the rosbag2 directory ``out``.

    Returns the number of samples. Deterministic: no wall-clock flushes, fixed stamps.
    """
    count = int(math.floor(duration * rate + 1e-9))
    start_ns = int(round(start_time * 1e9))
    simulator = Simulator(config)
    with Rosbag2McapWriter(out, compression=compression, flush_period_s=None) as writer:
        writer.add_topic(JOINT_STATES, JOINT_STATE_TYPE)
        writer.add_topic(TRUTH_FRICTION, VECTOR3_STAMPED_TYPE)
        writer.add_topic(TRUTH_EFFICIENCY, VECTOR3_STAMPED_TYPE)
        for first in range(0, count, CHUNK):
            index = np.arange(first, min(first + CHUNK, count))
            # integer-nanosecond stamps, no accumulated rounding: stamp_k = start + k/rate
            stamps_ns = start_ns + np.round(index * (1e9 / rate)).astype(np.int64)
            result = simulator.sample((stamps_ns - start_ns) * 1e-9)
            _write_chunk(writer, result, stamps_ns, first, list(names), truth_every)
    return count


def run(args: argparse.Namespace) -> int:
    _check(args)
    config = _config(args)
    out: Path = args.out
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise CliError(f'--out {out} exists and is not an empty directory')
    try:
        count = write_simulation(out, config, args.duration, args.rate, args.start_time,
                                 (args.motor_joint, args.load_joint), args.truth_every,
                                 None if args.compression == 'none' else args.compression)
    except ValueError as exc:   # e.g. the wear trajectory jams the gearbox within the run
        raise CliError(str(exc)) from None
    except (OSError, BagError) as exc:
        raise CliError(f'cannot write {out}: {exc}') from None
    print(f'wrote {count} samples ({args.duration:g} s at {args.rate:g} Hz) to {out}')
    return 0
