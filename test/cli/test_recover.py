"""``gear-phm recover``'s options and refusals (gear_phm.cli.recover); the recovery: bagio/."""
from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from gear_phm.cli.main import CliError
from gear_phm.cli.recover import add_arguments, run


def test_a_path_is_required_and_out_is_optional(tmp_path: Path) -> None:
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args([str(tmp_path / 'bag')])
    assert (args.path, args.out) == (tmp_path / 'bag', None)
    assert parser.parse_args(['b', '--out', 'c']).out == Path('c')
    with pytest.raises(SystemExit):
        parser.parse_args([])


def test_a_path_that_is_not_there_is_one_line(tmp_path: Path) -> None:
    missing = tmp_path / 'no_bag'
    with pytest.raises(CliError, match=f'^not found: {missing}$'):
        run(argparse.Namespace(path=missing, out=None))
    assert list(tmp_path.iterdir()) == []
