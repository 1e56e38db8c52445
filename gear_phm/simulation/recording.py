"""Simulated runs written as rosbag2 MCAP bags: one drive, many drives, a fleet of units.

:func:`write_simulation` writes one drive's joint states and truth, :func:`write_drives` many
drives in one JointState stream, :func:`write_fleet` a tree of units with recordings separated
by idle time. Stamps and log times are ``start_time + k / rate``; the output is byte-for-byte
the same for the same arguments (no wall-clock time is written). ``gear-phm simulate`` is the
command-line layer over this module.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
import errno
import math
from pathlib import Path
import shutil

import numpy as np

from gear_phm import stopping
from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.bagio.batch_writer import stamped_float64_rows
from gear_phm.codec import joint_state_rows
from gear_phm.interfaces import (BASIC_TRUTH_TOPICS, JOINT_STATE_TYPE, JOINT_STATES,
                                 OIL_TEMPERATURE, TEMPERATURE_FIELDS,
                                 TEMPERATURE_TYPE, TRUTH_LAYOUT, TRUTH_NO_LOAD, TRUTH_OIL,
                                 VECTOR3_STAMPED_TYPE)
from gear_phm.parameters import LOAD_JOINT, MOTOR_JOINT
from gear_phm.run import DriveNames
from gear_phm.simulation.simulator import SimulationConfig, SimulationResult, Simulator

#: The default (motor, load) joint names.
JOINT_NAMES = (str(MOTOR_JOINT.default), str(LOAD_JOINT.default))
#: Samples simulated per chunk (bounds memory for long runs).
CHUNK = 20_000
#: Bytes written before the bag's final size is projected from them (:func:`write_drives`).
PROJECT_AFTER = 4 << 20
#: Every stamp is before this time [s since the epoch]: builtin_interfaces/Time's seconds are
#: an int32 (2**31 s: 03:14:08 UTC on 19 January 2038).
STAMP_LIMIT = float(2**31)

#: One drive of :func:`write_drives`: its configuration, its (motor, load) joint names and its
#: name (None: the only drive).
Drive = tuple[SimulationConfig, tuple[str, str], str | None]
#: A truth topic: its name, its message type and the SimulationResult arrays its float64
#: fields hold ('': 0), from :data:`gear_phm.interfaces.TRUTH_LAYOUT`.
TruthTopic = tuple[str, str, tuple[str, ...]]


@dataclass(frozen=True)
class Fleet:
    """A fleet of :func:`write_fleet`: ``units`` units of ``recordings`` recordings each.

    ``gap`` [s] of idle time between recordings, each times a log-normal factor of spread
    ``gap_spread`` (0: every gap equal); ``unit_spread``: unit-to-unit relative (log-normal)
    spread of the wear's initial friction and rate.
    """

    units: int
    recordings: int = 1
    gap: float = 7 * 86400.0
    gap_spread: float = 0.0
    unit_spread: float = 0.2


def check_end(end: float, what: str) -> None:
    """Raise ValueError if a run's end, ``what`` [s since the epoch], is not before STAMP_LIMIT."""
    if not end < STAMP_LIMIT:
        msg = (f'{what} must end before {STAMP_LIMIT:.0f} s since the epoch (the int32 '
               f'seconds of a ROS stamp end in 2038), got {end:.10g} s')
        raise ValueError(msg)


def truth_topics(config: SimulationConfig, drive: str | None = None) -> list[TruthTopic]:
    """Return the truth topics written for a drive of ``config`` (``drive``: of many, or None).

    The friction and efficiency truth always; the no-load and oil truth with
    ``config.extended_truth``; the oil temperature with ``config.publish_temperature``.
    """
    layout = dict(TRUTH_LAYOUT)
    bases = BASIC_TRUTH_TOPICS + ((TRUTH_NO_LOAD, TRUTH_OIL) if config.extended_truth else ())
    topics: list[TruthTopic] = [(_topic(base, drive), VECTOR3_STAMPED_TYPE, layout[base])
                                for base in bases]
    if config.publish_temperature:
        topics.append((_topic(OIL_TEMPERATURE, drive), TEMPERATURE_TYPE, TEMPERATURE_FIELDS))
    return topics


def _topic(topic: str, drive: str | None) -> str:
    return DriveNames.chosen(drive).topic(topic)


def write_chunk(writer: Rosbag2McapWriter, results: Sequence[SimulationResult],
                stamps_ns: np.ndarray, first_index: int, names: Sequence[str],
                truth_every: int, topics: Sequence[Sequence[TruthTopic]]) -> None:
    """Write one chunk of samples, packed as CDR rows at once.

    Per sample one JointState of every drive's joints (``names``: motor then load of each
    result), then (every ``truth_every``-th sample of the run) each drive's truth
    (``topics``: :func:`truth_topics` of each result; the basic truth of every drive first,
    then the rest): for one drive the order the message-by-message writer had.
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
    basic = [(result, topic, fields) for result, drive in zip(results, topics)
             for topic, _, fields in drive[:len(BASIC_TRUTH_TOPICS)]]
    extended = [(result, topic, fields) for result, drive in zip(results, topics)
                for topic, _, fields in drive[len(BASIC_TRUTH_TOPICS):]]
    truth_rows = [(topic, stamped_float64_rows(stamps_ns[truth], np.column_stack(
        [getattr(result, name)[truth] if name else zero for name in fields])))
        for result, topic, fields in basic + extended]
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
    return write_drives(out, [(config, names, None)], duration, rate, start_time, truth_every,
                        compression, operating_offset)


def write_drives(out: Path, drives: Sequence[Drive],
                 duration: float, rate: float, start_time: float = 0.0, truth_every: int = 1,
                 compression: str | None = 'zstd', operating_offset: float = 0.0) -> int:
    """Simulate drives in one JointState stream into the rosbag2 directory ``out``.

    ``drives``: per drive its configuration, its (motor, load) joint names and its name
    (None: the only drive, truth on ``gear_phm/truth/...``; else on
    ``gear_phm/<drive>/truth/...``). Each drive has its own simulator; all share the stamps
    and must share their idle gap, whose samples are not written. Returns the number of
    samples (JointState messages); see :func:`write_simulation`.

    Raises ValueError if the drives' idle gaps differ, and OSError (ENOSPC) as soon as the
    bag's size, projected from what has been written, exceeds the free space of ``out``'s
    file system: a long run is refused in its first megabytes, not when the disk is full.
    """
    gaps = {config.idle_gap for config, _, _ in drives}
    if len(gaps) > 1:
        msg = 'the drives of one stream must share their idle gap (idle_gap_at, ' \
              'idle_gap_duration)'
        raise ValueError(msg)
    gap = gaps.pop()
    count = int(math.floor(duration * rate + 1e-9))
    start_ns = int(round(start_time * 1e9))
    simulators = [Simulator(config) for config, _, _ in drives]
    names = [name for _, pair, _ in drives for name in pair]
    topics = [truth_topics(config, drive) for config, _, drive in drives]
    written = 0
    with Rosbag2McapWriter(out, compression=compression, flush_period_s=None,
                           batch=True) as writer:
        writer.add_topic(JOINT_STATES, JOINT_STATE_TYPE)
        for part in (slice(0, len(BASIC_TRUTH_TOPICS)), slice(len(BASIC_TRUTH_TOPICS), None)):
            for topic, kind, _ in (entry for drive in topics for entry in drive[part]):
                writer.add_topic(topic, kind)
        for first in range(0, count, CHUNK):
            stopping.check()            # a signal's stop that was swallowed
            index = np.arange(first, min(first + CHUNK, count))
            # integer-nanosecond stamps, no accumulated rounding: stamp_k = start + k/rate
            stamps_ns = start_ns + np.round(index * (1e9 / rate)).astype(np.int64)
            times = operating_offset + (stamps_ns - start_ns) * 1e-9
            if gap.enabled:
                running = ~gap.idle(times)
                stamps_ns, times = stamps_ns[running], times[running]
                if not times.size:
                    continue
            with np.errstate(over='ignore', invalid='ignore'):  # refused by check_finite
                results = [simulator.sample(times) for simulator in simulators]
            for (_, joints, _), result in zip(drives, results):
                check_finite(result, joints if len(drives) > 1 else None)
            write_chunk(writer, results, stamps_ns, written, names, truth_every, topics)
            written += len(stamps_ns)
            check_space(out, first + index.size, count)
    return written


#: The fields of a SimulationResult that are written.
WRITTEN = ('position_motor', 'position_load', 'velocity_motor', 'velocity_load', 'effort_motor',
           'effort_load', 'u', 'friction', 'eta_opposing', 'eta_aiding')


def check_finite(result: SimulationResult, joints: tuple[str, str] | None) -> None:
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


def check_space(out: Path, done: int, count: int) -> None:
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


def write_fleet(out: Path, config: SimulationConfig, fleet: Fleet, duration: float,
                rate: float, start_time: float = 0.0, names: tuple[str, str] = JOINT_NAMES,
                truth_every: int = 1, compression: str | None = 'zstd') -> int:
    """Write units ``unit_00``... with ``fleet.recordings`` bags each and ``truth.yaml``.

    Each recording lasts ``duration`` [s]. Returns the number of samples written. Raises
    ValueError when the unit spread draws an unusable wear or a unit ends past
    :data:`STAMP_LIMIT`.
    """
    import yaml
    rng = np.random.default_rng(config.seed)
    gap_rng = np.random.default_rng([config.seed, 1])     # leaves the units' draws unchanged
    total = 0
    # each recording starts from the oil's initial temperature (the gap between recordings
    # is not simulated); the plant's clock is the operating time
    for unit in range(fleet.units):
        spread = fleet.unit_spread
        # an overflow to inf is refused below (Wear, check_end), with the option to blame
        with np.errstate(over='ignore'):
            initial = float(config.wear.initial * np.exp(spread * rng.standard_normal()))
            wear_rate = float(config.wear.rate * np.exp(spread * rng.standard_normal()))
            gaps = fleet.gap * np.exp(fleet.gap_spread * gap_rng.standard_normal(fleet.recordings))
            starts = [start_time + k * duration + float(np.sum(gaps[:k]))
                      if fleet.gap_spread else start_time + k * (duration + fleet.gap)
                      for k in range(fleet.recordings)]
        try:
            wear = replace(config.wear, initial=initial, rate=wear_rate)
        except ValueError as exc:
            msg = (f'unit {unit}: --unit-spread {spread:g} drew an unusable wear ({exc}); '
                   f'lower --unit-spread')
            raise ValueError(msg) from None
        check_end(starts[-1] + duration,
                  f'unit {unit}: --start-time + --recordings x --duration + the gaps')
        unit_config = replace(config, wear=wear)
        folder = out / f'unit_{unit:02d}'
        for k, start in enumerate(starts):
            # the unit's stochastic wear path runs on across its recordings
            recording = replace(unit_config, seed=config.seed * 10_000 + unit * 100 + k,
                                wear_seed=config.seed * 10_000 + unit * 100,
                                oil=replace(config.oil, start=k * duration))
            total += write_simulation(
                folder / f'rec_{k:03d}', recording, duration, rate, start,
                names, truth_every, compression,
                operating_offset=k * duration)
        truth = {'ratio': config.plant.ratio, 'plant': config.plant.efficiency_model,
                 'wear': {'kind': wear.kind, 'initial': initial, 'rate': wear_rate,
                          't_fault': wear.t_fault, 'step': wear.step,
                          'exponent': wear.exponent},
                 'recording_duration_s': duration, 'gap_s': fleet.gap,
                 'gap_spread': fleet.gap_spread,
                 'recording_start_s': starts, 'rate_hz': rate, 'seed': config.seed,
                 'note': 'wear advances with operating time only: the friction value of the '
                         'plant at operating time s is wear(s); recording k covers '
                         'operating time [k d, (k + 1) d), d = recording_duration_s'}
        (folder / 'truth.yaml').write_text(yaml.safe_dump(truth, sort_keys=False))
    return total
