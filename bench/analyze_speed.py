"""Benchmark (not a test): gear-phm analyze samples/s next to rosbags raw reading/decoding.

Both are measured on the same bag in the same run.
Usage: .venv/bin/python bench/analyze_speed.py [BAG]
"""
from __future__ import annotations

from pathlib import Path
import sys
import tempfile
import time

from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores

from gear_phm.cli.main import main as gear_phm
from gear_phm.offline.summary import read_summary


def rosbags_rates(bag: Path, topic: str = '/joint_states') -> tuple[float, float, int]:
    """(raw read msgs/s, read + deserialize msgs/s, count) with rosbags AnyReader."""
    store = get_typestore(Stores.ROS2_JAZZY)
    rates = []
    for deserialize in (False, True):
        with AnyReader([bag], default_typestore=store) as reader:
            conns = [c for c in reader.connections if c.topic == topic]
            start = time.perf_counter()
            count = 0
            for conn, _, raw in reader.messages(connections=conns):
                if deserialize:
                    reader.deserialize(raw, conn.msgtype)
                count += 1
            rates.append(count / (time.perf_counter() - start))
    return rates[0], rates[1], count


def main() -> None:
    bag = Path(sys.argv[1] if len(sys.argv) > 1 else 'bags/wearing')
    raw_rate, decode_rate, count = rosbags_rates(bag)
    with tempfile.TemporaryDirectory() as tmp:
        gear_phm(['analyze', str(bag), '--ratio', '3.0', '--out', f'{tmp}/out', '--no-plot',
                  '--no-progress'])
        run = read_summary(f'{tmp}/out').run
    print(f'bag {bag}: {count} JointState messages')
    print(f'rosbags raw read           : {raw_rate:10.0f} msg/s')
    print(f'rosbags read + deserialize : {decode_rate:10.0f} msg/s')
    print(f'gear-phm analyze           : {run.samples_per_second:10.0f} samples/s '
          f'({100 * run.samples_per_second / decode_rate:.0f} % of deserialize)')


if __name__ == '__main__':
    main()
