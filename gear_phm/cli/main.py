"""Entry point of ``gear-phm``: dispatch to one module per subcommand.

Each subcommand module exposes ``HELP`` (one line), ``add_arguments(parser)`` and
``run(args) -> int``. Errors the user can fix raise :class:`CliError`; they are printed as
``gear-phm <command>: error: <message>`` on one line with exit status 2, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

SUBCOMMANDS: dict[str, str] = {
    'paper': 'gear_phm.cli.paper',
    'simulate': 'gear_phm.cli.simulate',
    'analyze': 'gear_phm.cli.analyze',
    'evaluate': 'gear_phm.cli.evaluate',
    'monitor': 'gear_phm.cli.monitor',
    'recover': 'gear_phm.cli.recover',
}


class CliError(Exception):
    """A problem with the user's input: printed on one line, exit status 2."""


def _available() -> dict[str, object]:
    modules = {}
    for name, module_name in SUBCOMMANDS.items():
        try:
            modules[name] = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name != module_name:
                raise
    return modules


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='gear-phm',
        description='Gearbox friction estimation and remaining useful life (gear_phm).')
    commands = parser.add_subparsers(dest='command', metavar='COMMAND', required=True)
    for name, module in _available().items():
        sub = commands.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(sub)
        sub.set_defaults(_run=module.run, _parser=sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except CliError as exc:
        print(f'gear-phm {args.command}: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f'gear-phm {args.command}: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
