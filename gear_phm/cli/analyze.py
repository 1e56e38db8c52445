"""``gear-phm analyze BAG --ratio R --out DIR``: run the estimator node's code over a bag.

Reads JointState from any rosbag2 (MCAP/sqlite3) or ROS1 bag, decodes it in large batches and
feeds :class:`gear_phm.estimation.EstimatorPipeline` (the code of the live node) as fast as it
can. Writes DIR as a rosbag2 MCAP directory with the node's topics (and its /diagnostics status
every second of bag time), stamped in bag time, plus DIR/summary.json and DIR/analysis.png.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import sys
import time
from typing import Any

import numpy as np

from gear_phm import interfaces
from gear_phm.cli.main import CliError
from gear_phm.estimation import EstimatorConfig, EstimatorPipeline, Measurement, PARAMETERS
from gear_phm.prognostics.options import add_health_arguments, health_config_from_args
from gear_phm.prognostics.pipeline import HealthPipeline

HELP = 'estimate friction offline from a recorded bag (same code as the estimator node)'
BATCH = 20000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('bag', help='rosbag2 directory, .mcap, .db3 or ROS1 .bag')
    parser.add_argument('--ratio', type=float, required=True,
                        help='ideal torque gain load/motor R = z2/z1 [-]')
    parser.add_argument('--motor-joint', default='motor', help='motor joint name')
    parser.add_argument('--load-joint', default='load', help='load joint name')
    parser.add_argument('--topic', default=interfaces.JOINT_STATES,
                        help='JointState topic (default joint_states)')
    parser.add_argument('--out', required=True, help='output directory (must not exist)')
    parser.add_argument('--param', action='append', default=[], metavar='NAME=VALUE',
                        help='estimator parameter, as in config/estimator.yaml (repeatable)')
    parser.add_argument('--transmission-name', default='gearbox',
                        help='diagnostics status name "gear_phm: <name>" (default gearbox)')
    parser.add_argument('--hardware-id', default='gearbox', help='diagnostics hardware_id')
    parser.add_argument('--diagnostics-rate', type=float, default=1.0, metavar='HZ',
                        help='/diagnostics rate in bag time [Hz], as the nodes (default 1.0)')
    parser.add_argument('--overwrite', action='store_true',
                        help='replace --out if it holds a previous analysis (summary.json)')
    parser.add_argument('--no-plot', action='store_true', help='skip the PNG')
    add_health_arguments(parser)
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def _config(args: argparse.Namespace) -> EstimatorConfig:
    values: dict[str, Any] = {'ratio': args.ratio}
    for item in args.param:
        name, sep, text = item.partition('=')
        if not sep:
            raise CliError(f'--param expects NAME=VALUE, got {item!r}')
        if name == 'backwards_policy':
            values[name] = text
        elif name in PARAMETERS:
            try:
                values[name] = int(text) if name == 'max_consecutive_gated' else float(text)
            except ValueError:
                raise CliError(f'--param {name} needs a number, got {text!r}') from None
        else:
            raise CliError(f'--param: unknown estimator parameter {name!r} '
                           f'(known: {", ".join(sorted(PARAMETERS))}, backwards_policy)')
    try:
        return EstimatorConfig(**values)
    except ValueError as exc:
        raise CliError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    from gear_phm.bagio import BagError, BagReader, Rosbag2McapWriter
    from gear_phm.bagio.writer import vector3_stamped_from_cdr

    config = _config(args)
    if not args.diagnostics_rate > 0:
        raise CliError(f'--diagnostics-rate must be > 0, got {args.diagnostics_rate}')
    out = Path(args.out)
    if args.overwrite and out.is_dir() and (out / 'summary.json').is_file():
        import shutil
        shutil.rmtree(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise CliError(f'--out {out} exists and is not an empty directory')
    if not Path(args.bag).exists():
        raise CliError(f'bag {args.bag} does not exist')
    measurements: list[tuple[Measurement, bool]] = []
    try:
        pipeline = EstimatorPipeline(config, args.motor_joint, args.load_joint,
                                     on_measurement=lambda m, ok: measurements.append((m, ok)))
    except ValueError as exc:
        raise CliError(str(exc)) from None
    try:
        health = HealthPipeline(health_config_from_args(args, config.ratio),
                                args.transmission_name, args.hardware_id)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    status_name = 'gear_phm estimator: estimator'
    levels: dict[str, int] = {}
    friction: list[tuple[int, float, float, float]] = []
    truth: dict[str, list[tuple[int, float, float, float]]] = {}
    try:
        with BagReader(args.bag) as bag:
            topic = bag.require_topic(args.topic, interfaces.JOINT_STATE_TYPE)
            total = bag.message_count(topic)
            if total == 0:
                raise CliError(f'topic {topic} in bag {args.bag} has no message')
            out.parent.mkdir(parents=True, exist_ok=True)
            started = time.perf_counter()
            samples = 0
            truth_topics = {} if args.no_plot else {
                bag.resolve_topic(name): name
                for name in (interfaces.TRUTH_FRICTION, interfaces.TRUTH_EFFICIENCY)
                if bag.resolve_topic(name) in bag.topics}
            diag_period_ns = int(1e9 / args.diagnostics_rate)
            with Rosbag2McapWriter(out) as writer:
                progress = _progress(total, args.no_progress)
                next_diag: int | None = None       # next /diagnostics tick, bag time [ns]
                last_log_ns = 0

                def process(decoded: interfaces.JointBatch, begin: int, end: int) -> None:
                    """Messages begin..end-1 of a decoded raw batch: estimator, then
                    diagnostics code."""
                    nonlocal samples
                    if end <= begin:
                        return
                    batch = decoded.messages(begin, end)
                    for reason, count in batch.rejected.items():
                        pipeline.reject_message(reason, count)
                    outputs = pipeline.on_batch(batch.stamp_ns, batch.motor_velocity,
                                                batch.motor_effort, batch.load_velocity,
                                                batch.load_effort)
                    samples += end - begin
                    records: list[Any] = []         # in the order the nodes publish them
                    for output in outputs:
                        records.append(output)
                        if output.topic == interfaces.FRICTION:
                            friction.append((output.stamp_ns, output.x, output.y, output.z))
                        # the diagnostics node's code, fed the same messages
                        records += health.on_input(output.topic, output.stamp_ns, output)
                    writer.write_outputs(records)

                for raw in bag.raw_batches([topic, *truth_topics], batch_size=BATCH):
                    if raw.topic != topic:           # ground truth, for the plot only
                        truth.setdefault(truth_topics[raw.topic], []).extend(
                            vector3_stamped_from_cdr(payload) for payload in raw.payloads())
                        continue
                    # /diagnostics as the nodes publish it at diagnostics_rate, in bag time:
                    # at each tick, the state after the messages logged before the tick
                    times = raw.log_time_ns
                    if next_diag is None:
                        next_diag = int(times[0]) + diag_period_ns
                    decoded = interfaces.decode_joint_state_buffer(
                        raw.buffer, raw.offsets, raw.lengths, args.motor_joint,
                        args.load_joint)
                    begin = 0
                    while next_diag <= int(times[-1]):
                        cut = int(np.searchsorted(times, next_diag, side='left'))
                        process(decoded, begin, cut)
                        begin = cut
                        writer.write_output(_diagnostics(next_diag, pipeline, status_name,
                                                         samples, health, args, levels))
                        next_diag += diag_period_ns
                    process(decoded, begin, len(raw))
                    last_log_ns = int(times[-1])
                    progress.update(len(raw))
                if next_diag is not None:            # the final state, at the last message
                    writer.write_output(_diagnostics(last_log_ns, pipeline, status_name,
                                                     samples, health, args, levels))
                progress.close()
                elapsed = time.perf_counter() - started
                reader_kind = bag.reader_kind
            if pipeline.samples_seen == 0:
                raise CliError(f'no message of topic {topic} has joints '
                               f'{args.motor_joint!r} and {args.load_joint!r}: '
                               f'{dict(pipeline.counts)}')
    except BagError as exc:
        raise CliError(str(exc)) from None
    summary = pipeline.summary()
    summary.update({
        'bag': str(args.bag), 'topic': args.topic, 'messages': samples, 'reader': reader_kind,
        'seconds': elapsed, 'samples_per_second': samples / elapsed if elapsed > 0 else math.inf,
        'windows_measured': len(measurements), 'config': config.as_dict(),
        'health': _health_summary(health, levels),
    })
    (out / 'summary.json').write_text(json.dumps(summary, indent=2, default=_json) + '\n')
    if not args.no_plot:
        _plot(out / 'analysis.png', config.ratio, friction, measurements, truth,
              pipeline, args.bag)
    print(f'u = {summary["u"]:.5f} +/- {summary["sigma_u"]:.5f}, eta_D = '
          f'{summary["eta_opposing"]:.4f}, eta_I = {summary["eta_aiding"]:.4f}; '
          f'{samples} messages in {elapsed:.2f} s ({summary["samples_per_second"]:.0f}/s) '
          f'-> {out}', file=sys.stderr)
    return 0


def _diagnostics(stamp_ns: int, pipeline: EstimatorPipeline, status_name: str, samples: int,
                 health: HealthPipeline, args: argparse.Namespace,
                 levels: dict[str, int]) -> interfaces.DiagnosticsOut:
    """The /diagnostics array the estimator and diagnostics nodes would publish at stamp_ns."""
    statuses = [pipeline.status(status_name, samples)]
    if health.latest is not None:
        statuses += health.latest.diagnostics(args.transmission_name,
                                              args.hardware_id).statuses
        levels.setdefault(interfaces.LEVEL_NAMES[health.latest.level], stamp_ns)
    return interfaces.DiagnosticsOut(stamp_ns, tuple(statuses))


def _health_summary(health: HealthPipeline, first_seen: dict[str, int]) -> dict[str, Any]:
    """Final health status and the bag time [ns] each level was first reported."""
    latest = health.latest
    if latest is None:
        return {'level': 'none', 'first_seen_ns': first_seen, 'dropped': health.dropped}
    return {'level': interfaces.LEVEL_NAMES[latest.level], 'message': latest.message,
            'values': dict(latest.key_values()), 'first_seen_ns': first_seen,
            'dropped': health.dropped}


def _json(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return str(value)


class _NoProgress:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def _progress(total: int, disabled: bool) -> Any:
    if disabled:
        return _NoProgress()
    from tqdm import tqdm
    return tqdm(total=total, unit='msg', unit_scale=True, file=sys.stderr, mininterval=0.5,
                desc='analyze')


def _plot(path: Path, ratio: float, friction: list, measurements: list, truth: dict,
          pipeline: EstimatorPipeline, bag: str) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from gear_phm.models import eta_aiding, eta_opposing
    if not friction:
        return
    f = np.array(friction)
    t0 = f[0, 0]
    t = (f[:, 0] - t0) * 1e-9
    u, sigma = f[:, 1], f[:, 3]
    fig, (ax_eta, ax_u) = plt.subplots(2, 1, sharex=True, figsize=(10, 7))
    ax_eta.plot(t, eta_opposing(np.maximum(u, -0.5), ratio), color='C0',
                label='eta_D from u_hat')
    ax_eta.plot(t, eta_aiding(np.maximum(u, -0.5), ratio), color='C1',
                label='eta_I from u_hat')
    if measurements:
        origin = pipeline._origin_ns if pipeline._origin_ns is not None else t0
        m_t = np.array([(origin + m.t * 1e9 - t0) * 1e-9 for m, _ in measurements])
        eta = np.array([m.eta for m, _ in measurements])
        code = np.array([m.code for m, _ in measurements])
        ok = np.array([a for _, a in measurements])
        for value, colour, label in ((1, 'C0', 'measured eta_D (window)'),
                                     (2, 'C1', 'measured eta_I (window)'),
                                     (3, 'C3', 'measured eta_I < 0 (self-locking)')):
            sel = code == value
            if sel.any():
                ax_eta.scatter(m_t[sel & ok], eta[sel & ok], s=8, color=colour, alpha=0.5,
                               label=label)
                if (sel & ~ok).any():
                    ax_eta.scatter(m_t[sel & ~ok], eta[sel & ~ok], s=14, marker='x',
                                   color=colour, label=label.replace('measured', 'gated'))
    if interfaces.TRUTH_EFFICIENCY in truth:
        e = np.array(truth[interfaces.TRUTH_EFFICIENCY])
        ax_eta.plot((e[:, 0] - t0) * 1e-9, e[:, 1], 'k--', lw=1, label='true eta_D')
        ax_eta.plot((e[:, 0] - t0) * 1e-9, e[:, 2], 'k:', lw=1, label='true eta_I')
    ax_eta.set_ylabel('efficiency [-]')
    ax_eta.legend(loc='best', fontsize=8)
    ax_eta.grid(alpha=0.3)
    ax_eta.set_title(f'gear-phm analyze {Path(bag).name}  (R = {ratio:g})')
    ax_u.fill_between(t, u - 2 * sigma, u + 2 * sigma, color='C2', alpha=0.3,
                      label='u_hat +/- 2 sigma')
    ax_u.plot(t, u, color='C2', label='u_hat')
    if interfaces.TRUTH_FRICTION in truth:
        tr = np.array(truth[interfaces.TRUTH_FRICTION])
        ax_u.plot((tr[:, 0] - t0) * 1e-9, tr[:, 1], 'k--', lw=1, label='true u')
    finite = np.isfinite(u)
    if finite.any():
        lo, hi = np.percentile(u[finite], [1, 99])
        pad = max(0.2 * (hi - lo), 0.01)
        ax_u.set_ylim(lo - pad, hi + pad)
        lo_e = min(eta_opposing(max(hi, 0.0), ratio), eta_aiding(max(hi, 0.0), ratio))
        ax_eta.set_ylim(lo_e - 0.1, 1.02)
    ax_u.set_xlabel('bag time [s]')
    ax_u.set_ylabel('friction parameter u [-]')
    ax_u.legend(loc='best', fontsize=8)
    ax_u.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
