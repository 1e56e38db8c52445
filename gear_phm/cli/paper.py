"""``gear-phm paper``: regenerate figures 3, 4, 6 of Berri et al. with statistics.

``--architecture NAME`` answers the paper's open question for one architecture (or ``all``):
the lever model against the reference model of that architecture (docs/paper-reproduction.md).
"""
from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TYPE_CHECKING

from gear_phm.cli.main import CliError

if TYPE_CHECKING:
    from gear_phm.paper.reproduce import SamplingRanges

HELP = 'reproduce the paper figures (simplified vs spur-gear model) with statistics'


def _bounded(convert: type, low: float, high: float | None = None) -> Callable[[str], Any]:
    """Make an argparse type: ``convert(text)`` (int or float) within [low, high].

    No upper bound if ``high`` is None; a one-line reason otherwise.
    """
    kind = 'a whole number' if convert is int else 'a number'

    def parse(text: str) -> Any:
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'expected {kind}, got {text!r}') from None
        if high is None and value < low:
            raise argparse.ArgumentTypeError(f'must be >= {low}, got {value}')
        if high is not None and not low <= value <= high:
            raise argparse.ArgumentTypeError(f'must be in [{low:g}, {high:g}], got {value:g}')
        return value
    return parse


_positive_int = _bounded(int, 1)
_seed = _bounded(int, 0)
_bearing_fraction = _bounded(float, 0.0, 10.0)
_tooth_friction = _bounded(float, 0.0, 2.0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from gear_phm.paper.architectures import ARCHITECTURES
    from gear_phm.paper.reproduce import DEFAULT_SAMPLES, DEFAULT_SEED, SamplingRanges
    parser.add_argument('--out', required=True, type=Path, metavar='DIR',
                        help='output directory (created if missing)')
    parser.add_argument('--seed', type=_seed, default=DEFAULT_SEED,
                        help=f'random seed of the gear sampling (default {DEFAULT_SEED})')
    parser.add_argument('--samples', type=_positive_int, default=DEFAULT_SAMPLES,
                        help=f'number of random reference gears (default {DEFAULT_SAMPLES})')
    parser.add_argument('--max-bearing-fraction', type=_bearing_fraction, default=None,
                        metavar='X',
                        help='upper end of the uniform bearing friction radius / pitch radius '
                             f'range (default {SamplingRanges().bearing_fraction[1]:g}; values '
                             'near 1 give irreversible gears)')
    parser.add_argument('--max-tooth-friction', type=_tooth_friction, default=None,
                        metavar='F',
                        help='upper end of the uniform tooth friction coefficient range of '
                             f'the gears (default {SamplingRanges().tooth_friction[1]:g})')
    parser.add_argument('--architecture', choices=(*ARCHITECTURES, 'all'), default=None,
                        help='compare the simplified model with the reference model of this '
                             'architecture (all: each into a subdirectory) and write '
                             "table.md / table.csv; default: the paper's spur figures only")


def run(args: argparse.Namespace) -> int:
    out: Path = args.out
    if out.exists() and not out.is_dir():
        raise CliError(f'--out {str(out)!r} exists and is not a directory')
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CliError(f'cannot create --out directory {str(out)!r}: {exc.strerror}') from None
    from gear_phm.paper.reproduce import FIGURE_FILES, SamplingRanges, reproduce
    ranges = SamplingRanges()
    if args.max_bearing_fraction is not None:
        ranges = replace(ranges, bearing_fraction=(0.0, args.max_bearing_fraction))
    if args.max_tooth_friction is not None:
        ranges = replace(ranges, tooth_friction=(0.0, args.max_tooth_friction))
    if args.architecture is not None:
        return _run_architectures(args, out, ranges)
    try:
        summary = reproduce(out, seed=args.seed, samples=args.samples, ranges=ranges)
    except OSError as exc:
        raise CliError(f'cannot write into {str(out)!r}: {exc.strerror}') from None
    e_tot = summary['e_tot']
    print(f'wrote {", ".join(FIGURE_FILES)}, samples.csv, summary.json to {out}')
    print(f'samples {summary["samples"]} (seed {summary["seed"]}), irreversible '
          f'{summary["irreversible_fraction"]:.1%}, no image on curve '
          f'{summary["no_image_on_curve"]}')
    print(f'e_tot median {e_tot["median"]:.3g}, p95 {e_tot["p95"]:.3g}, below 1e-2 '
          f'{summary["e_tot_fraction_below_1e-2"]:.1%}; |e_D| median '
          f'{summary["abs_error_opposing"]["median"]:.3g}, |e_I| median '
          f'{summary["abs_error_aiding"]["median"]:.3g}')
    return 0


def _run_architectures(args: argparse.Namespace, out: Path, ranges: SamplingRanges) -> int:
    """Run --architecture NAME (or all), print the table."""
    from gear_phm.paper.architectures import ARCHITECTURES, figure_files, run
    names = ARCHITECTURES if args.architecture == 'all' else (args.architecture,)
    try:
        table = run(names, out, seed=args.seed, samples=args.samples, ranges=ranges)
    except OSError as exc:
        raise CliError(f'cannot write into {str(out)!r}: {exc.strerror}') from None
    for name in names:
        where = out if len(names) == 1 else out / name
        print(f'{name}: wrote {", ".join(figure_files(name))}, samples.csv, summary.json to '
              f'{where}')
    print(f'wrote table.md, table.csv to {out} (seed {args.seed}, {args.samples} samples each)')
    print(table, end='')
    return 0
