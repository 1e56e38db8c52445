"""Shared helpers for bench/ scripts: timing and appending results to docs/benchmarks.md."""
from __future__ import annotations

from collections.abc import Callable
import datetime as _dt
import os
from pathlib import Path
import platform
import shlex
import sys
import time

BENCHMARKS_MD = Path(__file__).resolve().parent.parent / 'docs' / 'benchmarks.md'


def best_of(func: Callable[[], object], repeat: int = 5) -> float:
    """Best wall time [s] of ``repeat`` calls (the least disturbed by the other core's load)."""
    best = float('inf')
    for _ in range(repeat):
        start = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - start)
    return best


def rss_mib(pid: int | str = 'self') -> float:
    """Resident set size [MiB] from /proc/<pid>/status."""
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        if line.startswith('VmRSS:'):
            return int(line.split()[1]) / 1024.0
    return float('nan')


def machine() -> str:
    return (f'{platform.machine()}, {os.cpu_count()} cores, Python '
            f'{platform.python_version()}')


def append_section(title: str, table: list[list[str]], notes: str = '',
                   out: Path | None = BENCHMARKS_MD) -> str:
    """Print a markdown section (date, command, machine, table) and append it to ``out``."""
    command = ' '.join(shlex.quote(a) for a in [Path(sys.argv[0]).as_posix(), *sys.argv[1:]])
    lines = [f'### {title}', '',
             f'- date: {_dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}',
             f'- command: `.venv/bin/python {command}`', f'- machine: {machine()}', '',
             '| ' + ' | '.join(table[0]) + ' |', '|' + '---|' * len(table[0])]
    lines += ['| ' + ' | '.join(row) + ' |' for row in table[1:]]
    if notes:
        lines += ['', notes]
    text = '\n'.join(lines) + '\n'
    print(text)
    if out is not None:
        with open(out, 'a', encoding='utf-8') as stream:
            stream.write('\n' + text)
    return text
