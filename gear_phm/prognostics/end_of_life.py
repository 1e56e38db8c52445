"""End of life of a transmission as a friction-parameter threshold u_eol [-]."""
from __future__ import annotations

import math

from gear_phm.models import u_from_eta_opposing
from gear_phm.models.lever import d_u_d_eta_opposing, eta_opposing
from gear_phm.prognostics.config import HEALTHY_SETTLED_SHARE

#: u at which eta_I = R (1 - u) / (R + u) reaches 0: onset of self-locking.
U_SELF_LOCKING = 1.0


def end_of_life_thresholds(ratio: float, eta_opposing_min: float, self_locking_eol: bool = True,
                           u_max: float = 0.0) -> dict[str, float]:
    """Return the enabled end-of-life criteria as {name: u threshold [-]}.

    ``eta_opposing_min``: u where eta_D falls to it (eq 13), always enabled.
    ``self_locking_eol``: u = 1, where eta_I = 0 (the assessor enables it for
    ``must_back_drive`` on a gearbox that back-drives when healthy,
    :func:`healthy_self_locking`). ``u_max`` > 0: u = u_max. Raises ValueError for an
    ``eta_opposing_min`` no u reaches or a negative or non-finite ``u_max``.
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


def healthy_self_locking(u_aiding: float, u_sigma: float) -> bool | None:
    """Whether a gearbox is self-locking when healthy, from its first settled estimate.

    ``u_aiding`` [-]: u as the aiding windows read it (eq 13 of the estimated eta_I), self-
    locking (eta_I <= 0) from U_SELF_LOCKING on; ``u_sigma`` [-] its standard deviation. The
    estimate decides once sigma_u is at most HEALTHY_SETTLED_SHARE of its distance from
    U_SELF_LOCKING (the filter has settled on one side); None until then (or when either is
    not finite).
    """
    if not (math.isfinite(u_aiding) and math.isfinite(u_sigma)):
        return None
    if not u_sigma <= HEALTHY_SETTLED_SHARE * abs(u_aiding - U_SELF_LOCKING):
        return None
    return bool(u_aiding >= U_SELF_LOCKING)


def u_accuracy(u_eol: float, ratio: float, eta_accuracy: float) -> float:
    """Return the systematic uncertainty of a measured u at ``u_eol`` [-].

    An efficiency known to +/- ``eta_accuracy`` [-] (sensor calibration, model accuracy)
    gives u to |du/deta_D| eta_accuracy at eta_D(u_eol) (eq 13's sensitivity).
    """
    eta = float(eta_opposing(u_eol, ratio))
    slope = float(d_u_d_eta_opposing(eta, ratio)) if math.isfinite(eta) else math.nan
    return abs(slope) * eta_accuracy if math.isfinite(slope) else 0.0
