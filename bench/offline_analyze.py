"""Offline speed: ``gear-phm analyze`` on a 1,000,000-sample bag, against decoding alone.

Measured in one run on the same bag (simulated, 1 kHz, --samples JointState messages, plus
the two ground-truth topics at 10 Hz):
- mcap raw iteration (mcap's reader, no decoding) -- the I/O floor;
- rosbags read + deserialize_cdr of every JointState -- the "decode with rosbags" baseline;
- gear_phm's vectorised JointState decoding alone (gear_phm.interfaces.decode_joint_states);
- ``gear-phm analyze`` end to end (read, decode, estimator, diagnostics, write outputs).
Reported as samples/s and as ratios to the rosbags and mcap baselines.

Usage: .venv/bin/python bench/offline_analyze.py [--samples 1000000] [--no-append]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import BENCHMARKS_MD, append_section  # noqa: E402

BIN = Path(sys.executable).parent


def timed(func) -> tuple[float, object]:
    start = time.perf_counter()
    result = func()
    return time.perf_counter() - start, result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--samples', type=int, default=1_000_000)
    parser.add_argument('--rate', type=float, default=1000.0, help='bag sample rate [Hz]')
    parser.add_argument('--no-append', action='store_true')
    args = parser.parse_args()
    from mcap.reader import make_reader

    from gear_phm.bagio import BagReader
    from gear_phm.bagio.writer import TYPESTORE
    from gear_phm.interfaces import JOINT_STATE_TYPE, decode_joint_states

    with tempfile.TemporaryDirectory() as tmp:
        bag = Path(tmp) / 'bag'
        duration = args.samples / args.rate
        subprocess.run([str(BIN / 'gear-phm'), 'simulate', '--out', str(bag), '--duration',
                        str(duration), '--rate', str(args.rate), '--wear', 'linear',
                        '--truth-every', str(max(int(args.rate / 10), 1)),
                        '--wear-rate', '1e-5', '--seed', '1'], check=True,
                       stdout=subprocess.DEVNULL)
        mcap_file = next(bag.glob('*.mcap'))

        def mcap_raw() -> int:
            with open(mcap_file, 'rb') as stream:
                return sum(1 for _, channel, _ in make_reader(stream).iter_messages()
                           if channel.topic == '/joint_states')

        def rosbags_decode() -> int:
            count = 0
            with BagReader(bag) as reader:
                for _, _, raw in reader.raw_messages(['joint_states']):
                    TYPESTORE.deserialize_cdr(raw, JOINT_STATE_TYPE)
                    count += 1
            return count

        def gear_phm_decode() -> int:
            with BagReader(bag) as reader:
                raws = [raw for _, _, raw in reader.raw_messages(['joint_states'])]
            return len(decode_joint_states(raws, 'motor', 'load'))

        t_mcap, n_mcap = timed(mcap_raw)
        t_rosbags, n_rosbags = timed(rosbags_decode)
        t_decode, n_decode = timed(gear_phm_decode)
        out = Path(tmp) / 'analysis'
        t_analyze, _ = timed(lambda: subprocess.run(
            [str(BIN / 'gear-phm'), 'analyze', str(bag), '--ratio', '3.0', '--out', str(out),
             '--no-plot', '--no-progress'], check=True, stdout=subprocess.DEVNULL))
        summary = json.loads((out / 'summary.json').read_text())
    n = n_rosbags
    assert n == n_mcap == n_decode, (n_mcap, n_rosbags, n_decode)
    rate = {name: n / t for name, t in (('mcap', t_mcap), ('rosbags', t_rosbags),
                                         ('decode', t_decode), ('analyze', t_analyze))}
    rows = [['stage', 'samples/s', 'ratio to rosbags decode', 'ratio to mcap raw']]
    for name, label in (('mcap', 'mcap raw iteration (no decoding)'),
                        ('rosbags', 'rosbags read + deserialize_cdr (baseline)'),
                        ('decode', 'gear_phm batch decode (read + decode_joint_states)'),
                        ('analyze', '`gear-phm analyze` end to end (process incl. start-up)')):
        rows.append([label, f'{rate[name]:,.0f}', f'{rate[name] / rate["rosbags"]:.2f}',
                     f'{rate[name] / rate["mcap"]:.2f}'])
    notes = (f'{n:,} JointState samples ({args.rate:.0f} Hz simulated bag, ground truth at '
             f'10 Hz as a rig bag would carry slow extra topics). analyze reported '
             f'{summary.get("samples_per_second", float("nan")):,.0f} samples/s for its own '
             'processing loop (without interpreter start-up and output writing).')
    append_section('Offline analysis speed', rows, notes,
                   out=None if args.no_append else BENCHMARKS_MD)
    return 0


if __name__ == '__main__':
    sys.exit(main())
