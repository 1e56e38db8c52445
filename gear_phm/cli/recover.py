"""``gear-phm recover DIR``: make a recording readable again after a crash (kill -9)."""
from __future__ import annotations

import argparse
from pathlib import Path

from gear_phm.bagio import BagError, BagReader, recover
from gear_phm.cli.main import CliError

HELP = 'rebuild a rosbag2 MCAP directory whose writer was killed (footer, metadata.yaml)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('directory', type=Path, help='rosbag2 directory holding the .mcap file')


def run(args: argparse.Namespace) -> int:
    directory: Path = args.directory
    if not directory.is_dir():
        raise CliError(f'not a directory: {directory}')
    try:
        count = recover(directory)
        with BagReader(directory) as bag:
            topics = bag.topics
    except (FileNotFoundError, BagError) as exc:
        raise CliError(str(exc)) from exc
    print(f'recovered {count} messages on {len(topics)} topics into {directory}')
    return 0
