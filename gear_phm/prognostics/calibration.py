"""The RUL band: quantiles of the time of reaching u_eol over the laws' parameter draws.

The parameters (u_end, r, shape) of each law are drawn from their Gaussian (fixed
standard-normal draws from a seed, :class:`Draws`: common random numbers, no jitter between
fits), each draw's first passage of u_eol after t_end is solved in closed form
(:func:`~gear_phm.prognostics.fits.crossing_offsets`; inf where the draw never reaches it, e.g.
r <= 0), and the 5/50/95 % inverted-CDF quantiles of the crossing time are kept
(:func:`crossing_quantiles`). Each law takes its Akaike weight's share of the draws.

Two uncertainties that no residual of the fit shows are added to each draw's crossing:

- the history's resolution: wear accrues unseen between two points, so the crossing lies
  anywhere within one mean spacing of the points (uniform);
- a systematic error of the measured u, ``u_systematic`` [-] at end of life (a sensor
  calibration or model accuracy, the same for every window, so it does not average out):
  the crossing moves by u_systematic / (du/dt at the crossing), normal.

Without them the band of a long, well-fitted history narrows to a fraction of a per cent of
the RUL and misses the truth, which the wear between two windows, or a measurement bias of
0.05 % of u, moves by more (docs/prognostics.md).
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from gear_phm.prognostics.fits import (crossing_offsets, crossing_slopes, P_FLOOR, Trend)
from gear_phm.prognostics.laws import LINEAR, POWER, PROPORTIONAL


@dataclass(frozen=True)
class Draws:
    """Fixed random numbers of the band's Monte Carlo (common random numbers).

    ``normals`` (3, n): the parameters' standard-normal draws; ``uniforms`` (n): which law a
    draw belongs to; ``phases`` (n): uniform in [-0.5, 0.5), the resolution's shift;
    ``systematic`` (n): standard normal, the systematic error's.
    """

    normals: np.ndarray
    uniforms: np.ndarray
    phases: np.ndarray
    systematic: np.ndarray

    @classmethod
    def seeded(cls, seed: int, samples: int) -> Draws:
        """Return ``samples`` draws from ``seed``."""
        rng = np.random.default_rng(seed)
        normals = rng.standard_normal((3, samples))
        uniforms = rng.random(samples)
        phases = rng.random(samples) - 0.5
        return cls(normals, uniforms, phases, rng.standard_normal(samples))


def inverted_cdf_quantiles(values: np.ndarray, probabilities: tuple[float, ...]
                           ) -> list[float]:
    """Return ``np.quantile(values, probabilities, method='inverted_cdf')`` from one sort.

    numpy's vectorised sort beats ``np.quantile``, and ``np.partition`` with several ranks,
    for a few thousand draws; the tests check they agree. NaN-free input.
    """
    n = values.size
    ordered = np.sort(values)
    return [float(ordered[max(math.ceil(p * n) - 1, 0)]) for p in probabilities]


def crossing_draws(laws: tuple[Trend, ...], draws: Draws, u_eol: float, u_systematic: float,
                   spacing: float) -> np.ndarray:
    """Return each draw's absolute time [s] of reaching ``u_eol`` (inf: never).

    Over the laws' parameter draws, each law taking its Akaike weight's share of the draws;
    ``u_systematic`` [-] and the history's mean ``spacing`` [s] as in the module docstring.
    """
    crossing = np.empty(draws.uniforms.size)
    edges = np.cumsum([law.weight for law in laws])
    edges[-1] = 1.0
    lower = 0.0
    for law, upper in zip(laws, edges):
        chosen = (draws.uniforms >= lower) & (draws.uniforms < upper)
        lower = upper
        if not chosen.any():
            continue
        k = 3 if law.model != LINEAR else 2
        cov = np.asarray(law.covariance).reshape(k, k)
        values, vectors = np.linalg.eigh(0.5 * (cov + cov.T))
        root = vectors * np.sqrt(np.maximum(values, 0.0))
        drawn = root @ draws.normals[:k, chosen]
        rate = law.slope + drawn[1]
        shape = law.shape + drawn[2] if k == 3 else np.zeros_like(rate)
        if k == 3:
            shape = np.clip(shape, law.shape_low, law.shape_high)
        if law.model == POWER:
            shape = np.maximum(shape, P_FLOOR)
        elif law.model == PROPORTIONAL:     # r = k u_end exactly, not to first order
            rate = (law.u_end + drawn[0]) * shape
        offsets = crossing_offsets(
            law.model, u_eol - (law.u_end + drawn[0]), rate, shape, law.span)
        if u_systematic > 0.0:
            with np.errstate(invalid='ignore'):
                offsets = offsets + u_systematic * draws.systematic[chosen] \
                    / crossing_slopes(law.model, offsets, rate, shape, law.span)
        crossing[chosen] = law.t_end + offsets
    # the resolution of the history: wear accrues between two points unseen, so the
    # crossing lies anywhere within one spacing
    crossing += spacing * draws.phases
    return crossing


def crossing_quantiles(laws: tuple[Trend, ...], draws: Draws, u_eol: float,
                       u_systematic: float, spacing: float) -> tuple[float, float, float]:
    """Return the 5/50/95 % quantiles [s] of :func:`crossing_draws` (inf: never)."""
    p5, median, p95 = inverted_cdf_quantiles(
        crossing_draws(laws, draws, u_eol, u_systematic, spacing), (0.05, 0.5, 0.95))
    return (p5, median, p95)
