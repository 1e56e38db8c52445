"""The analysis plot (gear_phm.offline.plot): its helpers and the plot process."""
from __future__ import annotations

from pathlib import Path
import subprocess
import sys

import numpy as np

from gear_phm.offline.plot import level_spans, true_end_of_life

REPO = Path(__file__).resolve().parents[2]


def test_plot_helpers_true_end_of_life_and_level_runs() -> None:
    truth = np.array([[0.0, 0.1], [1e9, 0.2], [2e9, 0.25], [3e9, 0.3]])    # stamp ns, u
    assert true_end_of_life(truth, 0.25) == 2_000_000_000       # first u >= u_eol, as evaluate
    assert true_end_of_life(truth, 0.5) is None and true_end_of_life(None, 0.25) is None
    t = np.arange(6.0)
    assert level_spans(t, np.array([0, 0, 1, 1, 1, 2])) == [(0.0, 2.0, 0), (2.0, 5.0, 1),
                                                            (5.0, 5.0, 2)]
    assert level_spans(t[:0], np.array([], dtype=int)) == []


PLOTTER = """
import sys
from pathlib import Path
from gear_phm.offline import analyze_bag
from gear_phm.offline.parallel import start_plotter
from gear_phm.offline.plot import plot_analysis
bag, out = Path(sys.argv[1]), Path(sys.argv[2])
plotter = start_plotter()                       # forked first: it imports matplotlib meanwhile
assert plotter is not None and 'matplotlib' not in sys.modules
analysis = analyze_bag(bag, ratio=3.0, plot=False)
plotter.plot([(out / 'plotter.png', analysis, 3.0, [bag], '')])
try:
    plotter.plot([(out / 'missing' / 'x.png', analysis, 3.0, [bag], '')])
except FileNotFoundError as exc:
    print('error came back:', type(exc).__name__)
plotter.close()
assert not plotter.process.is_alive(), 'the plot process outlived close()'
assert 'matplotlib' not in sys.modules, 'the caller imported matplotlib'
plot_analysis(out / 'here.png', analysis, 3.0, [bag])
"""


def test_the_plot_process_draws_what_this_process_would(tmp_path: Path) -> None:
    """``gear-phm analyze`` forks a process that imports matplotlib while it analyses.

    Its plot's pixels equal the plot drawn in the analysing process; its error comes back to
    the caller; it ends on close; the caller never imports matplotlib for it.
    """
    from matplotlib.image import imread
    result = subprocess.run([sys.executable, '-c', PLOTTER, str(REPO / 'bags' / 'wearing'),
                             str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ['error came back: FileNotFoundError']
    ours, theirs = imread(str(tmp_path / 'plotter.png')), imread(str(tmp_path / 'here.png'))
    assert ours.shape == theirs.shape and ours.shape[0] > 400
    np.testing.assert_allclose(ours, theirs, atol=1e-6)
