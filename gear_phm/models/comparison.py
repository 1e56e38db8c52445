"""Distance between a reference-model point and the simplified model (Berri et al., eq 15)."""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from gear_phm.models._validation import finite, positive
from gear_phm.models.lever import eta_aiding_from_opposing, eta_opposing_from_aiding


def total_squared_error(eta_opposing_ref: ArrayLike, eta_aiding_ref: ArrayLike,
                        ratio: ArrayLike) -> np.ndarray | float:
    """Squared normal distance e_tot [-] of (eta_D, eta_I) to the simplified curve at ``ratio``.

    e_I = eta_I,ref - eta_I(eta_D,ref) is the vertical and e_D = eta_D,ref - eta_D(eta_I,ref) the
    horizontal distance to the curve of eq 14. Replacing the curve by the chord between those
    two curve points, the normal distance is the altitude of the right triangle::

        e_tot = (e_I e_D / sqrt(e_D^2 + e_I^2))^2 = e_I^2 e_D^2 / (e_D^2 + e_I^2)      (15)

    0 for a point on the curve. NaN where the point has no image on the curve.
    """
    eta_d = finite('eta_opposing_ref', eta_opposing_ref)
    eta_i = finite('eta_aiding_ref', eta_aiding_ref)
    ratio = positive('ratio', ratio)
    error_i = eta_i - eta_aiding_from_opposing(eta_d, ratio)
    error_d = eta_d - eta_opposing_from_aiding(eta_i, ratio)
    sum_sq = error_d ** 2 + error_i ** 2
    safe = np.where(sum_sq > 0.0, sum_sq, 1.0)
    result = np.where(sum_sq > 0.0, (error_i * error_d) ** 2 / safe, 0.0)
    result = np.where(np.isnan(sum_sq), np.nan, result)
    return float(result) if result.ndim == 0 else result
