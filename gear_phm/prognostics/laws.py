"""Names of the wear laws the RUL fits (:mod:`gear_phm.prognostics.fits`, docs/prognostics.md).

Their own module so that the parameters (:mod:`gear_phm.prognostics.config`, the ``trend``
choices) and the RUL predictor (which takes its defaults from those parameters) both import
them without importing each other.
"""
from __future__ import annotations

LINEAR, EXPONENTIAL, POWER, NONE = 'linear', 'exponential', 'power', 'none'
PROPORTIONAL = 'proportional'
MODELS: tuple[str, ...] = (LINEAR, EXPONENTIAL, POWER, PROPORTIONAL)
#: The laws with a shape (k or p): a population prior can be learned for them.
SHAPED: tuple[str, ...] = (EXPONENTIAL, POWER, PROPORTIONAL)
#: The laws of the exponential form u_end + r (exp(k s) - 1) / k: they share its basis,
#: crossing, slope and rise (proportional: r = k u_end).
EXPONENTIAL_FORM: tuple[str, ...] = (EXPONENTIAL, PROPORTIONAL)
