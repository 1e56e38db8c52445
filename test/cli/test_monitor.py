"""``gear-phm monitor``'s options (gear_phm.cli.monitor); the run itself: integration/."""
from __future__ import annotations

import argparse

import pytest

from gear_phm.cli.main import CliError
from gear_phm.cli.monitor import add_arguments, run


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return parser


def test_the_options_and_their_defaults() -> None:
    args = _parser().parse_args(['--params-file', 'a.yaml', '--params-file', 'b.yaml',
                                 '--executor', 'events'])
    assert (args.params_file, args.executor, args.linger, args.no_publisher) == (
        ['a.yaml', 'b.yaml'], 'events', 2.0, False)
    with pytest.raises(SystemExit):
        _parser().parse_args(['--executor', 'threads'])


def test_a_negative_linger_is_refused_before_any_node_starts() -> None:
    args = _parser().parse_args(['--linger', '-1'])
    args.ros_args = []
    with pytest.raises(CliError, match=r'^--linger must be >= 0, got -1\.0$'):
        run(args)
