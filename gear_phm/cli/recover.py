"""``gear-phm recover PATH [--out OUT]``: make a recording readable again.

After a crash (``kill -9``) or damage, without rewriting the original and without laundering
bad bytes.

PATH is a rosbag2 directory (recovered in place, each replaced file kept as ``<name>.orig``,
or into the new directory ``--out``) or one ``.mcap`` file (recovered into ``--out``, by
default ``<stem>.recovered.mcap`` beside it; an ``--out`` without ``.mcap`` suffix becomes a
rosbag2 directory; ``.db3``, ``.bag``... are refused). A directory whose MCAP files are intact
but whose metadata.yaml the rosbag2 reader refuses gets a new one (the old kept as
``metadata.yaml.orig``). Every dropped range is printed on stderr with its byte offsets, log
times and message count; the exit status is 0 when the output was written or nothing was
needed, 2 (one-line error, nothing written) when the input is not MCAP, holds nothing to
recover, or the output is in the way.
"""
from __future__ import annotations

import argparse
from pathlib import Path
import sys

from gear_phm.bagio import recover, RecoverError
from gear_phm.bagio.metadata import METADATA_FILE
from gear_phm.cli.main import CliError

HELP = 'rebuild a recording after a crash or damage (originals kept, bad chunks dropped)'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('path', type=Path,
                        help='rosbag2 directory holding the .mcap file(s), or one .mcap file')
    parser.add_argument('--out', type=Path, default=None,
                        help='write the recovered bag here (a new directory, or a .mcap file '
                             'for a .mcap input) instead of in place with .orig backups')


def run(args: argparse.Namespace) -> int:
    path: Path = args.path
    if not path.exists():
        raise CliError(f'not found: {path}')
    try:
        result = recover(path, args.out)
    except RecoverError as exc:
        raise CliError(' '.join(str(exc).split())) from None
    except OSError as exc:
        where = f'{exc.filename}: ' if exc.filename is not None else ''
        raise CliError(f'cannot recover {path}: {where}{exc.strerror or exc}') from None
    if result.metadata_problem is not None:
        print(f'{path / METADATA_FILE}: refused by the rosbag2 reader '
              f'({result.metadata_problem}); rebuilt from the MCAP files', file=sys.stderr)
    for source, dropped in result.dropped:
        print(f'{source.name}: dropped {dropped.describe()}', file=sys.stderr)
    unchecked = sum(s.unchecked_chunks for s in result.scans)
    if unchecked:
        print(f'{path}: {unchecked} chunks carry no CRC; their content could not be checked',
              file=sys.stderr)
    if result.nothing_to_do:
        print(f'{path}: complete and intact ({result.messages} messages on {result.topics} '
              f'topics); nothing to recover, nothing written')
        return 0
    kept = f' (originals kept as {", ".join(p.name for p in result.backups)})' \
        if result.backups else ''
    print(f'recovered {result.messages} messages on {result.topics} topics into '
          f'{result.output}{kept}')
    return 0
