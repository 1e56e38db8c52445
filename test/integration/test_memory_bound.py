"""Memory of offline analysis does not grow with the bag: a bound on peak RSS, not a timing.

Each analysis runs in its own process; its peak RSS comes from ``os.wait4``
(``bench/memory.py`` measures the same up to 40M samples, docs/benchmarks.md). Before
the histories were bounded, 100k samples of 1 kHz with truth peaked 54 % above 10k
(111 -> 171 MiB; now 104 -> 105 MiB).
"""
from __future__ import annotations

import os
from pathlib import Path
import subprocess
import sys

import pytest


GEAR_PHM = Path(sys.executable).parent / 'gear-phm'

#: Allowed growth of the peak from a bag to one ten times longer [-] (measured: 1-3 %).
GROWTH = 0.15


def _peak_mib(command: list[str]) -> float:
    """Run ``command`` to completion; return its own peak RSS [MiB]."""
    child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert child.stderr is not None
    errors = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, errors.decode()[-2000:]
    return usage.ru_maxrss / 1024.0


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    """Return simulated 1 kHz bags with truth of 10k and 100k samples."""
    folder = tmp_path_factory.mktemp('memory_bound')
    out = {}
    for samples in (10_000, 100_000):
        out[samples] = folder / f'bag_{samples}'
        subprocess.run([str(GEAR_PHM), 'simulate', '--duration', str(samples // 1000),
                        '--rate', '1000', '--out', str(out[samples])], check=True,
                       capture_output=True)
    return out


def test_analyze_peak_rss_does_not_grow_with_the_bag(bags: dict[int, Path],
                                                     tmp_path: Path) -> None:
    """gear-phm analyze with truth and plot: 100k samples peak within 15 % of 10k."""
    peaks = []
    for samples, bag in bags.items():
        peaks.append(_peak_mib([str(GEAR_PHM), 'analyze', str(bag), '--ratio', '3', '--out',
                                str(tmp_path / f'out_{samples}'), '--no-progress']))
        assert (tmp_path / f'out_{samples}' / 'analysis.png').is_file()
    small, large = peaks
    assert large <= (1 + GROWTH) * small, f'peak RSS {small:.0f} -> {large:.0f} MiB'


def test_python_api_peak_rss_does_not_grow_with_the_bag(bags: dict[int, Path]) -> None:
    """analyze_bag with its default options: 100k samples peak within 15 % of 10k."""
    script = ('import sys; from gear_phm.offline import analyze_bag; '
              'result = analyze_bag(sys.argv[1], 3.0); '
              'assert result.summary.run.messages == int(sys.argv[2]), result.summary')
    small, large = (_peak_mib([sys.executable, '-c', script, str(bag), str(samples)])
                    for samples, bag in bags.items())
    assert large <= (1 + GROWTH) * small, f'peak RSS {small:.0f} -> {large:.0f} MiB'
