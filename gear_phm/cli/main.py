"""Entry point of ``gear-phm``: dispatch to one module per subcommand.

Each subcommand module exposes ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args) -> int``. Errors the user can fix raise :class:`CliError`; they are printed as
``gear-phm <command>: error: <message>`` on one line with exit status 2, never a traceback.
"""
from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
import functools
import importlib
import signal
import sys
from types import FrameType
from typing import Any

from gear_phm import staging, stopping
from gear_phm.errors import GearPhmError

#: name -> (module, one-line help). Only the module of the command being run is imported.
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    'paper': ('gear_phm.cli.paper', "regenerate the paper's figures 3, 4, 6 and samples.csv"),
    'simulate': ('gear_phm.cli.simulate', 'write a simulated rosbag2 MCAP bag'),
    'analyze': ('gear_phm.cli.analyze', "run the live nodes' code over a recorded bag"),
    'evaluate': ('gear_phm.cli.evaluate', 'score RUL predictions with prognostic metrics'),
    'monitor': ('gear_phm.cli.monitor', 'run publisher, estimator and diagnostics in one '
                                        'process'),
    'recover': ('gear_phm.cli.recover', 'rebuild a recording after a crash (kill -9)'),
    'fleet': ('gear_phm.cli.fleet', 'analyse a fleet: one folder of recordings per unit, in '
                                    'parallel on Dask'),
}


#: Commands whose process stops on SIGTERM as on Ctrl-C: staged outputs are removed, nothing
#: half-written is left (monitor runs ROS nodes; rclpy handles its signals).
STOPPED_ON_SIGTERM = frozenset(SUBCOMMANDS) - {'monitor'}


class CliError(GearPhmError):
    """A problem with the user's input: printed on one line, exit status 2."""


def _terminate(signum: int, frame: FrameType | None, command: str) -> None:
    """On SIGTERM: SystemExit(128 + 15) in the main thread, so that cleanup (finally) runs.

    Also recorded (:mod:`gear_phm.stopping`): raised again at the next chunk or batch if
    this one is swallowed.
    """
    print(f'gear-phm {command}: terminated', file=sys.stderr)
    stopping.request(functools.partial(SystemExit, 128 + signum))
    raise SystemExit(128 + signum)


def _interrupt(signum: int, frame: FrameType | None) -> None:
    """On SIGINT: KeyboardInterrupt, recorded as :func:`_terminate` records SIGTERM."""
    stopping.request(KeyboardInterrupt)
    raise KeyboardInterrupt


def quiet_stop(default: Callable[[Any], object]) -> Callable[[Any], None]:
    """Return a ``sys.unraisablehook`` that does not print a swallowed recorded stop.

    A handler's SystemExit or KeyboardInterrupt that landed where Python cannot raise it (an
    import's lock callback, a finalizer) would print 'Exception ignored in ...' with a
    traceback; it is recorded (:mod:`gear_phm.stopping`) and raised again later, so the user
    sees the one line of a stop. Anything else goes to ``default``.
    """
    def hook(unraisable: Any) -> None:
        stop = isinstance(unraisable.exc_value, (SystemExit, KeyboardInterrupt))
        if stop and stopping.requested():
            return
        default(unraisable)
    return hook


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the ``gear-phm`` parser.

    Only ``command``'s module is imported (fast, and one broken subcommand cannot break the
    others).
    """
    parser = argparse.ArgumentParser(
        prog='gear-phm',
        description='Gearbox friction estimation and remaining useful life (gear_phm).')
    commands = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        sub = commands.add_parser(name, help=help_text, description=help_text)
        if name == command:
            module = importlib.import_module(module_name)
            module.add_arguments(sub)
            sub.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ros_args: list[str] = []
    if '--ros-args' in argv:            # everything from --ros-args on belongs to ROS
        ros_args = argv[argv.index('--ros-args'):]
        argv = argv[:argv.index('--ros-args')]
    command = next((a for a in argv if not a.startswith('-')), None)
    parser = build_parser(command if command in SUBCOMMANDS else None)
    args = parser.parse_args(argv)
    args.ros_args = ros_args
    if args.command in STOPPED_ON_SIGTERM:
        signal.signal(signal.SIGTERM, functools.partial(_terminate, command=args.command))
        signal.signal(signal.SIGINT, _interrupt)
        sys.unraisablehook = quiet_stop(sys.unraisablehook)
    try:
        return int(args._run(args) or 0)
    except CliError as exc:
        print(f'gear-phm {args.command}: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'gear-phm {args.command}: interrupted', file=sys.stderr)
        return 130
    finally:        # a stop that came while a staging folder was being made
        staging.discard_all()


if __name__ == '__main__':
    # Run the imported module's main, so that CliError is the class subcommands raise
    # (under `python -m`, this file is __main__ and would define a second CliError).
    from gear_phm.cli.main import main as _main
    sys.exit(_main())
