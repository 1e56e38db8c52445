"""At most one estimate per stamp, whatever the batch split (no ROS).

Two estimates can share a stamp: a window that closes at the sample a publish falls on, or
two windows closed by one sample. :class:`OnePerStamp` keeps the first of each stamp; the
filter state of a dropped one is in the next estimate anyway, and its measurement is carried
to the next estimate with the filter's rate and combined with that one's own by inverse
variance.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
import math

from gear_phm.estimation.records import FrictionEstimate
from gear_phm.estimation.state import Carry


class OnePerStamp:
    """The stamp of the newest estimate kept, and a measurement carried to the next one.

    ``last_stamp`` [ns] (None before the first estimate); ``carry``: (u [-], variance [-^2],
    operating time it holds at [s], direction share h [-], bias subtracted [-]) of the
    measurements of dropped estimates, or None.
    """

    def __init__(self, last_stamp: int | None = None, carry: Carry | None = None) -> None:
        self.last_stamp = last_stamp
        self.carry = carry

    def keep(self, outputs: Sequence[FrictionEstimate]
             ) -> tuple[list[FrictionEstimate], list[bool]]:
        """Return the estimates kept, in order, and whether each output was kept.

        An estimate whose stamp equals the previous one's is dropped; its measurement goes
        to the next kept one (:meth:`merged`).
        """
        kept, keep = [], []
        for output in outputs:
            if output.stamp_ns == self.last_stamp:
                if math.isfinite(output.measurement):
                    z, variance, h, bias = self.merged(output)
                    self.carry = (z, variance, output.operating_time, h, bias)
                keep.append(False)
                continue
            self.last_stamp = output.stamp_ns
            if self.carry is not None:
                z, variance, h, bias = self.merged(output)
                output = replace(output, measurement=z, measurement_variance=variance,
                                 measurement_direction=h, measurement_bias=bias)
                self.carry = None
            kept.append(output)
            keep.append(True)
        return kept, keep

    def merged(self, output: FrictionEstimate) -> tuple[float, float, float, float]:
        """Combine the carried measurement (if any) with ``output``'s own by inverse variance.

        The carried one is first moved to ``output``'s operating time with its rate. Returns
        (u [-], variance, direction share h [-], bias subtracted [-]), h and the bias with the
        same weights.
        """
        z, variance = output.measurement, output.measurement_variance
        h, bias = output.measurement_direction, output.measurement_bias
        if self.carry is None:
            return z, variance, h, bias
        cz, cv, at, ch, cb = self.carry
        cz += output.rate * (output.operating_time - at)
        if not math.isfinite(z):
            return cz, cv, ch, cb
        total = 1.0 / cv + 1.0 / variance
        return ((cz / cv + z / variance) / total, 1.0 / total,
                (ch / cv + h / variance) / total, (cb / cv + bias / variance) / total)
