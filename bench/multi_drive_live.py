"""Live CPU per message of one estimator serving 8 drives against a one-drive estimator.

Both estimators take the same stream at once (measured in one run): the publisher node
simulates a bench of ``--drives`` drives (16 joints for 8) plus 4 unrelated joints in one
JointState at ``--rate`` Hz for ``--duration`` s. Estimator A serves all drives
(``transmissions``), estimator B the first drive only (``motor_joint``/``load_joint``/
``ratio``, today's single transmission). CPU time of each process (all threads, from
/proc/<pid>/task/*/schedstat) over the stream, divided by the messages it received (its
/diagnostics ``messages_received``). The issue's bound: A at most 3x B per message.

Usage: .venv/bin/python bench/multi_drive_live.py [--rate 1000] [--duration 20] [--drives 8]
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parent))
from live_pipeline import cpu_ns, load_average, Observer  # noqa: E402
import yaml  # noqa: E402

from _report import append_section, BENCHMARKS_MD  # noqa: E402

BIN = Path(sys.executable).parent
#: ratio, initial friction, wear rate [1/s] of the drives
DRIVES = [(3.0, 0.08, 2e-4), (5.0, 0.05, 1e-4), (8.0, 0.04, 2e-4), (12.0, 0.03, 1e-4),
          (16.0, 0.06, 1e-4), (20.0, 0.02, 2e-4), (25.0, 0.05, 1e-4), (30.0, 0.02, 2e-4)]
EXTRA = ['brake_a', 'brake_b', 'hyd_p', 'tank_t']


def bench_parameters(drives: int) -> dict[str, object]:
    """Return the ``/**`` node parameters of a bench of ``drives`` drives d0, d1, ..."""
    parameters: dict[str, object] = {'transmissions': [f'd{k}' for k in range(drives)]}
    for k in range(drives):
        ratio, initial, rate = DRIVES[k % len(DRIVES)]
        parameters[f'd{k}'] = {'motor_joint': f'm{k}', 'load_joint': f'l{k}', 'ratio': ratio,
                               'simulation': {'wear': 'linear', 'friction_initial': initial,
                                              'wear_rate': rate}}
    return {'/**': {'ros__parameters': parameters}}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rate', type=float, default=1000.0)
    parser.add_argument('--duration', type=float, default=20.0)
    parser.add_argument('--drives', type=int, default=8)
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    os.environ.setdefault('ROS_DOMAIN_ID', str(150 + os.getpid() % 50))
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    load_before = load_average()
    with tempfile.TemporaryDirectory() as tmp:
        params = Path(tmp) / 'bench.yaml'
        params.write_text(yaml.safe_dump(bench_parameters(args.drives)))
        many = [str(BIN / 'estimator'), '--ros-args', '--params-file', str(params),
                '-r', '__node:=estimator_many']
        one = [str(BIN / 'estimator'), '--ros-args', '-r', '__node:=estimator_one', '-p',
               'motor_joint:=m0', '-p', 'load_joint:=l0', '-p',
               f'ratio:={DRIVES[0][0]}']
        publisher = [str(BIN / 'publisher'), '--ros-args', '--params-file', str(params),
                     '-p', f'rate:={args.rate}', '-p', f'duration:={args.duration}',
                     '-p', 'wait_for_subscribers:=2', '-p', 'truth_every:=1000',
                     '-p', f'extra_joints:=[{",".join(EXTRA)}]']
        observer = Observer()
        procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                 for cmd in (many, one)]
        try:
            names = ('gear_phm estimator: d0', 'gear_phm estimator: estimator_one')
            if not observer.spin_until(lambda: all(n in observer.counts for n in names), 60.0):
                raise SystemExit('the estimators did not start')
            before = [cpu_ns(p.pid) for p in procs]
            start = time.monotonic()
            feed = subprocess.Popen(publisher, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL)
            sent = int(args.rate * args.duration)
            observer.spin_until(lambda: feed.poll() is not None, args.duration + 120.0)
            observer.spin_until(lambda: all(observer.counts[n] >= sent for n in names), 10.0)
            observer.spin_for(1.5)
            after = [cpu_ns(p.pid) for p in procs]
            elapsed = time.monotonic() - start
            got = [observer.counts[n] for n in names]
        finally:
            for proc in procs:
                proc.terminate()
                proc.wait(timeout=20)
            observer.close()
    per = [(a - b) / max(n, 1) * 1e-3 for a, b, n in zip(after, before, got)]
    row = [f'{args.drives}', f'{args.rate:.0f}', f'{args.duration:.0f}', f'{per[0]:.0f}',
           f'{per[1]:.0f}', f'{per[0] / per[1]:.2f}', f'{got[0]} / {got[1]} / {sent}']
    print(f'{args.drives} drives: {per[0]:.0f} us/msg; one drive: {per[1]:.0f} us/msg; ratio '
          f'{per[0] / per[1]:.2f}; received {got[0]} / {got[1]} of {sent} ({elapsed:.1f} s)')
    note = (f'Command: `.venv/bin/python bench/multi_drive_live.py --rate {args.rate:g} '
            f'--duration {args.duration:g} --drives {args.drives}`. The stream: the '
            f'publisher node simulating the drives plus 4 unrelated joints in one '
            f'JointState. Load average before the run: {load_before}; after: '
            f'{load_average()} (2 cores, shared with other jobs).')
    append_section('Live: one estimator serving many drives, CPU per message against '
                   'a one-drive estimator on the same stream',
                   [['drives', 'rate [Hz]', 'duration [s]', 'many drives [us/msg]',
                     'one drive [us/msg]', 'ratio', 'received many / one / sent'], row],
                   note, out=None if args.no_append else BENCHMARKS_MD)
    return 0


if __name__ == '__main__':
    sys.exit(main())
