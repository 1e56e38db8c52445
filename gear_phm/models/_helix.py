"""Coulomb friction on a helical thread: the worm and the screws (see docs/architectures.md).

A thread of lead angle ``gamma`` carries a load along its axis (screw) or on the wheel tooth
(worm). The flank normal is inclined by the normal flank (pressure) angle ``alpha_n`` in the
plane normal to the thread. Coulomb friction ``mu N`` acts along the thread against the
sliding, so the equivalent friction angle on the helix is::

    tan(phi') = mu / cos(alpha_n)

and the balance of the thread as an inclined plane (power in over power out) gives::

    eta_D = tan(gamma) / tan(gamma + phi')       the screw (worm) drives the nut (wheel)
    eta_I = tan(gamma - phi') / tan(gamma)       the nut (wheel) drives the screw (worm)

eta_I <= 0 exactly when gamma <= phi': the drive is self-locking (it holds its load and the
motor must push it down as well). gamma + phi' >= pi/2 would jam the thread even when driven;
it is refused.
"""
from __future__ import annotations

import numpy as np

from gear_phm.models._validation import ModelError, result


def friction_angle(friction: np.ndarray, normal_angle: np.ndarray) -> np.ndarray:
    """Equivalent friction angle phi' [rad] of a Coulomb coefficient on an inclined flank."""
    angle: np.ndarray = np.arctan(friction / np.cos(normal_angle))
    return angle


def thread_efficiencies(lead_angle: np.ndarray, friction_angle: np.ndarray,
                        name: str = 'friction') -> tuple[np.ndarray, np.ndarray]:
    """(eta_D, eta_I) [-] of a thread; ModelError naming ``name`` if it jams when driven."""
    total = lead_angle + friction_angle
    bad = np.broadcast_to(total >= np.pi / 2, np.broadcast(lead_angle, friction_angle).shape)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
        where = f' at index {index}' if index else ''
        msg = (f'{name} too high for the lead angle{where}: lead angle + friction angle '
               f'{float(np.broadcast_to(total, bad.shape)[index]):.4g} rad >= pi/2, the '
               'thread jams even when driven')
        raise ModelError(msg) from None
    tan_lead = np.tan(lead_angle)
    eta_d: np.ndarray = tan_lead / np.tan(total)
    eta_i: np.ndarray = np.tan(lead_angle - friction_angle) / tan_lead
    return eta_d, eta_i


class ThreadDrive:
    """What the worm and the screws share, from their lead and friction angles."""

    def _angles(self) -> tuple[np.ndarray, np.ndarray]:
        """(lead angle, friction angle phi') [rad]."""
        raise NotImplementedError

    @property
    def self_locking(self) -> np.ndarray | bool:
        """Tell where the lead angle <= phi': the load cannot back-drive it (eta_I <= 0)."""
        lead, friction = self._angles()
        locking = lead <= friction
        return bool(locking) if locking.ndim == 0 else locking

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-]: the thread driving, then driven. eta_I may be <= 0."""
        eta_d, eta_i = thread_efficiencies(*self._angles())
        return result(eta_d), result(eta_i)
