"""``analysis.png`` of an :class:`~gear_phm.offline.Analysis` (matplotlib, Agg backend)."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gear_phm import interfaces
from gear_phm.models import eta_aiding, eta_opposing
from gear_phm.models.power_flow import AIDING, OPPOSING, SELF_LOCKING

if TYPE_CHECKING:
    from gear_phm.offline.engine import Analysis


def plot_analysis(path: Path, analysis: Analysis, ratio: float, bags: Sequence[Path]) -> None:
    """Plot measured and estimated efficiency (top), u with its 2-sigma band (bottom).

    Both against bag time [s], with the ground truth where the bag carries it.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    e = analysis.estimates
    if e.stamp_ns.size == 0:
        return
    t0 = int(e.stamp_ns[0])
    t = (e.stamp_ns - t0) * 1e-9
    u, sigma = e.u, e.u_sigma
    fig, (ax_eta, ax_u) = plt.subplots(2, 1, sharex=True, figsize=(10, 7))
    ax_eta.plot(t, eta_opposing(np.maximum(u, -0.5), ratio), color='C0',
                label='eta_D from u_hat')
    ax_eta.plot(t, eta_aiding(np.maximum(u, -0.5), ratio), color='C1',
                label='eta_I from u_hat')
    if analysis.measurements:
        m_t = np.array([(stamp - t0) * 1e-9 for stamp, _, _ in analysis.measurements])
        eta = np.array([m.eta for _, m, _ in analysis.measurements])
        code = np.array([m.code for _, m, _ in analysis.measurements])
        ok = np.array([accepted for _, _, accepted in analysis.measurements])
        for value, colour, label in ((OPPOSING, 'C0', 'measured eta_D (window)'),
                                     (AIDING, 'C1', 'measured eta_I (window)'),
                                     (SELF_LOCKING, 'C3', 'measured eta_I < 0 (self-locking)')):
            sel = code == value
            if sel.any():
                ax_eta.scatter(m_t[sel & ok], eta[sel & ok], s=8, color=colour, alpha=0.5,
                               label=label)
                if (sel & ~ok).any():
                    ax_eta.scatter(m_t[sel & ~ok], eta[sel & ~ok], s=14, marker='x',
                                   color=colour, label=label.replace('measured', 'gated'))
    truth_eta = analysis.truth.get(interfaces.TRUTH_EFFICIENCY)
    if truth_eta is not None and truth_eta.size:
        ax_eta.plot((truth_eta[:, 0] - t0) * 1e-9, truth_eta[:, 1], 'k--', lw=1,
                    label='true eta_D')
        ax_eta.plot((truth_eta[:, 0] - t0) * 1e-9, truth_eta[:, 2], 'k:', lw=1,
                    label='true eta_I')
    ax_eta.set_ylabel('efficiency [-]')
    ax_eta.legend(loc='best', fontsize=8)
    ax_eta.grid(alpha=0.3)
    names = ', '.join(Path(b).name for b in bags[:3]) + (' ...' if len(bags) > 3 else '')
    ax_eta.set_title(f'gear-phm analyze {names}  (R = {ratio:g})')
    ax_u.fill_between(t, u - 2 * sigma, u + 2 * sigma, color='C2', alpha=0.3,
                      label='u_hat +/- 2 sigma')
    ax_u.plot(t, u, color='C2', label='u_hat')
    truth_u = analysis.truth.get(interfaces.TRUTH_FRICTION)
    if truth_u is not None and truth_u.size:
        ax_u.plot((truth_u[:, 0] - t0) * 1e-9, truth_u[:, 1], 'k--', lw=1, label='true u')
    finite = np.isfinite(u)
    if finite.any():
        lo, hi = np.percentile(u[finite], [1, 99])
        pad = max(0.2 * (hi - lo), 0.01)
        ax_u.set_ylim(lo - pad, hi + pad)
        lo_e = min(eta_opposing(max(hi, 0.0), ratio), eta_aiding(max(hi, 0.0), ratio))
        ax_eta.set_ylim(lo_e - 0.1, 1.02)
    ax_u.set_xlabel('bag time [s]')
    ax_u.set_ylabel('friction parameter u [-]')
    ax_u.legend(loc='best', fontsize=8)
    ax_u.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
