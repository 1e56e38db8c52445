"""End of life of a transmission as a friction-parameter threshold u_eol [-]."""
from __future__ import annotations

import math

from gear_phm.models import u_from_eta_opposing
from gear_phm.models.lever import d_u_d_eta_opposing, eta_opposing

#: u at which eta_I = R (1 - u) / (R + u) reaches 0: onset of self-locking.
U_SELF_LOCKING = 1.0


def end_of_life_thresholds(ratio: float, eta_opposing_min: float, self_locking_eol: bool = True,
                           u_max: float = 0.0) -> dict[str, float]:
    """Return the enabled end-of-life criteria as {name: u threshold [-]}.

    ``eta_opposing_min``: u where eta_D falls to it (eq 13), always enabled.
    ``self_locking_eol``: u = 1, where eta_I = 0. ``u_max`` > 0: u = u_max.
    """
    u_eta = float(u_from_eta_opposing(eta_opposing_min, ratio))
    if not math.isfinite(u_eta):
        raise ValueError(f'eta_opposing_min must be > -1/ratio = {-1.0 / ratio:.4g}, '
                         f'got {eta_opposing_min!r}')
    thresholds = {'eta_opposing_min': u_eta}
    if self_locking_eol:
        thresholds['self_locking'] = U_SELF_LOCKING
    if u_max < 0.0 or not math.isfinite(u_max):
        raise ValueError(f'u_max must be finite and >= 0 (0 disables it), got {u_max!r}')
    if u_max > 0.0:
        thresholds['u_max'] = float(u_max)
    return thresholds


def end_of_life_u(ratio: float, eta_opposing_min: float, self_locking_eol: bool = True,
                  u_max: float = 0.0) -> tuple[float, str]:
    """Threshold u_eol [-] = min of the enabled criteria, and the name of the binding one."""
    thresholds = end_of_life_thresholds(ratio, eta_opposing_min, self_locking_eol, u_max)
    name = min(thresholds, key=thresholds.__getitem__)
    return thresholds[name], name


def u_accuracy(u_eol: float, ratio: float, eta_accuracy: float) -> float:
    """Return the systematic uncertainty of a measured u at ``u_eol`` [-].

    An efficiency known to +/- ``eta_accuracy`` [-] (sensor calibration, model accuracy)
    gives u to |du/deta_D| eta_accuracy at eta_D(u_eol) (eq 13's sensitivity).
    """
    eta = float(eta_opposing(u_eol, ratio))
    slope = float(d_u_d_eta_opposing(eta, ratio)) if math.isfinite(eta) else math.nan
    return abs(slope) * eta_accuracy if math.isfinite(slope) else 0.0
