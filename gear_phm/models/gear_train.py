"""Stages in series: multi-stage gear trains and planetary reducers (docs/architectures.md).

The stages are listed from the motor to the load; stage k has the ratio R_k (ideal torque
gain) and the efficiencies eta_D,k, eta_I,k. The train's ratio is R = prod R_k.

Opposing load (motor drives): the power P entering stage k leaves it as eta_D,k P, so::

    eta_D = prod eta_D,k

defined where every eta_D,k > 0 (a stage with eta_D,k <= 0 jams the train whatever the load:
NaN). Aiding load (the load drives): the power p entering stage k from its load side reaches
its motor side as eta_I,k p while p > 0. A self-locking stage (eta_I,k < 0) turns it negative:
from there on the stages towards the motor are driven by the motor, each asking for
|p| / eta_D,j at its input. Walking from the load to the motor::

    p <- 1;  for each stage from the load end:  p <- p eta_I,k  if p > 0  else  p / eta_D,k
    eta_I = p

which is prod eta_I,k while every stage is reversible ("stages in series multiply") and stays
negative, the more so behind a self-locking stage, when one is not.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from gear_phm.models._validation import ModelError, result


class Stage(Protocol):
    """What a stage of a train offers: its ratio and efficiencies (the reference models)."""

    @property
    def ratio(self) -> np.ndarray | float:
        """Ideal torque gain load / motor [-] (> 0)."""

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-]."""


def series_efficiencies(stages: Sequence[tuple[np.ndarray | float, np.ndarray | float]]
                        ) -> tuple[np.ndarray | float, np.ndarray | float]:
    """(eta_D, eta_I) [-] of stages (eta_D,k, eta_I,k) in series, motor first; see the module."""
    if not stages:
        msg = 'stages must hold at least one stage, got none'
        raise ModelError(msg) from None
    pairs = [(np.asarray(d, dtype=float), np.asarray(i, dtype=float)) for d, i in stages]
    eta_d = np.ones(np.broadcast_shapes(*(np.shape(d) for d, _ in pairs)))
    jammed = np.zeros(eta_d.shape, dtype=bool)
    for stage_d, _ in pairs:
        eta_d = eta_d * stage_d
        jammed = jammed | (stage_d <= 0.0)
    power = np.ones(np.broadcast_shapes(eta_d.shape, *(np.shape(i) for _, i in pairs)))
    stuck = np.zeros(power.shape, dtype=bool)
    for stage_d, stage_i in reversed(pairs):
        driven = power <= 0.0
        stuck = stuck | (driven & (stage_d <= 0.0))
        safe_d = np.where(stage_d > 0.0, stage_d, 1.0)
        power = np.where(driven, power / safe_d, power * stage_i)
    return (result(np.where(jammed, np.nan, eta_d)), result(np.where(stuck, np.nan, power)))


@dataclass(frozen=True)
class GearTrain:
    """Stages in series, motor first: spur, helical, planetary stages or any :class:`Stage`.

    stages: a non-empty tuple of reference models (their array fields broadcast together).
    Raises ModelError naming ``stages`` if it is empty or holds something that is not a stage.
    """

    stages: tuple[Stage, ...]

    def __post_init__(self) -> None:
        stages = tuple(self.stages)
        if not stages:
            msg = 'stages must hold at least one stage, got none'
            raise ModelError(msg) from None
        for index, stage in enumerate(stages):
            if not (hasattr(stage, 'ratio') and callable(getattr(stage, 'efficiencies', None))):
                msg = (f'stages[{index}] must be a stage model (ratio and efficiencies()), '
                       f'got {stage!r:.60}')
                raise ModelError(msg) from None
        object.__setattr__(self, 'stages', stages)

    @property
    def ratio(self) -> np.ndarray | float:
        """Transmission ratio R = prod R_k [-]."""
        ratio = np.ones(())
        for stage in self.stages:
            ratio = ratio * np.asarray(stage.ratio, dtype=float)
        return result(ratio)

    def efficiencies(self) -> tuple[np.ndarray | float, np.ndarray | float]:
        """(eta_opposing, eta_aiding) [-] of the train (see the module); NaN where it jams."""
        return series_efficiencies([stage.efficiencies() for stage in self.stages])
