"""The diagnostics node's recording cost, for two source trees (before and after a change).

The diagnostics node records through ``Rosbag2McapWriter.write_raw`` from its writer thread
and flushes every ``record_flush_period`` (0.5 s). This replays that load without DDS: per
second of node time, 10 health updates (``gear_phm/health/rul`` and ``/efficiency``, with
``--inputs`` also the six estimator topics) and one ``/diagnostics`` array of two statuses,
a flush every 0.5 s, for ``--seconds`` of node time. Each tree runs in its own process (its
directory first on sys.path), alternately, ``--repeat`` times; reported: CPU time per second
of node time, as a share of one core, and the ratio B / A.

Usage: .venv/bin/python bench/recorder_cost.py TREE_A TREE_B [--seconds 3600] [--repeat 3]
       [--inputs]
"""
from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import json, sys, time, tempfile
from pathlib import Path
from gear_phm.bagio import Rosbag2McapWriter
from gear_phm.bagio.writer import diagnostic_array_cdr
from gear_phm.interfaces import DiagnosticsOut, Vector3Out
from gear_phm.status import StatusOut
try:
    from gear_phm.interfaces import vector3_stamped_cdr
except ImportError:                      # older trees: in the writer module
    from gear_phm.bagio.writer import vector3_stamped_cdr
seconds, inputs = int(sys.argv[1]), sys.argv[2] == '1'
topics = ['gear_phm/health/rul', 'gear_phm/health/efficiency']
if inputs:
    topics += ['gear_phm/friction', 'gear_phm/friction_covariance', 'gear_phm/efficiency',
               'gear_phm/innovation', 'gear_phm/counts', 'gear_phm/operating_time']
values = tuple((f'key_{i}', f'{0.1 * i:.6g}') for i in range(16))
array = DiagnosticsOut(0, (StatusOut(0, 'gear_phm estimator: estimator', 'estimating',
                                     'gear_phm', values),
                           StatusOut(0, 'gear_phm: gearbox', 'ok', 'gearbox', values)))
# the node serialises in its callbacks; its writer thread (timed here) writes and flushes
payloads = {topic: [vector3_stamped_cdr(Vector3Out(topic, k * 10**8, 0.1 * k, 0.2, 0.3))
                    for k in range(10)] for topic in topics}
diagnostics = diagnostic_array_cdr(array)
with tempfile.TemporaryDirectory() as tmp:
    start = time.process_time()
    with Rosbag2McapWriter(Path(tmp) / 'rec', compression=None,
                           flush_period_s=None) as writer:
        writer.add_topic('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray')
        for topic in topics:
            writer.add_topic(topic, 'geometry_msgs/msg/Vector3Stamped')
        for second in range(seconds):
            for k in range(10):
                t = second * 10**9 + k * 10**8
                for topic in topics:
                    writer.write_raw(topic, t, payloads[topic][k])
                if k % 5 == 4:
                    writer.flush()
            writer.write_raw('/diagnostics', second * 10**9, diagnostics)
    print(json.dumps({'cpu': time.process_time() - start,
                      'records': seconds * (10 * len(topics) + 1)}))
"""


def run(tree: Path, seconds: int, inputs: bool) -> dict:
    done = subprocess.run([sys.executable, '-c', CHILD, str(seconds), '1' if inputs else '0'],
                          cwd=tree, env={**os.environ, 'PYTHONPATH': str(tree)},
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('a', type=Path)
    parser.add_argument('b', type=Path)
    parser.add_argument('--seconds', type=int, default=3600)
    parser.add_argument('--repeat', type=int, default=3)
    parser.add_argument('--inputs', action='store_true')
    args = parser.parse_args()
    cpu: dict[int, list[float]] = {0: [], 1: []}
    records = 0
    with tempfile.TemporaryDirectory():
        for _ in range(args.repeat):
            for k, tree in enumerate((args.a.resolve(), args.b.resolve())):
                result = run(tree, args.seconds, args.inputs)
                cpu[k].append(result['cpu'])
                records = result['records']
    a, b = (statistics.median(cpu[k]) for k in (0, 1))
    print(f'{args.seconds} s of node time, {records} records'
          f'{" (inputs recorded)" if args.inputs else ""}, medians of {args.repeat}')
    print('| tree | CPU [s] | us per record | share of one core |')
    print('|---|---|---|---|')
    for name, value in (('A', a), ('B', b)):
        print(f'| {name} | {value:.2f} | {1e6 * value / records:.1f} | '
              f'{100 * value / args.seconds:.3f} % |')
    print(f'\nB / A = {b / a:.2f}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
