"""Physics of Berri et al. (numpy only, vectorised, SI units). See docs/paper-errata.md.

Simplified lever model: :func:`eta_opposing` (eq 10), :func:`eta_aiding` (eq 12),
:func:`u_from_eta_opposing` (eq 13), :func:`u_from_eta_aiding`,
:func:`eta_aiding_from_opposing` (eq 14) and :func:`eta_opposing_from_aiding`.
Reference spur-gear model (eqs 1-8): :class:`SpurGear`. Other architectures
(docs/architectures.md): :class:`HelicalGear`, :class:`InternalGear` (pinion-ring mesh),
:class:`PlanetaryGearSet`, :class:`WormGear`, :class:`LeadScrew`, :class:`BallScrew`,
:class:`RollerScrew`, and stages in series :class:`GearTrain` (:func:`series_efficiencies`).
Comparison: :func:`total_squared_error` (eq 15). A bad argument raises :class:`ModelError`
(a ``ValueError``) naming it.
"""
from gear_phm.models._validation import ModelError
from gear_phm.models.comparison import total_squared_error
from gear_phm.models.gear_train import GearTrain, series_efficiencies, Stage
from gear_phm.models.helical_gear import HelicalGear
from gear_phm.models.internal_gear import InternalGear
from gear_phm.models.lever import (
    d_u_d_eta_aiding,
    d_u_d_eta_opposing,
    efficiencies,
    eta_aiding,
    eta_aiding_from_opposing,
    eta_opposing,
    eta_opposing_from_aiding,
    u_from_eta_aiding,
    u_from_eta_opposing,
)
from gear_phm.models.planetary import PlanetaryGearSet
from gear_phm.models.screw import BallScrew, LeadScrew, RollerScrew
from gear_phm.models.spur_gear import min_teeth, SpurGear
from gear_phm.models.worm import WormGear

__all__ = [
    'BallScrew', 'GearTrain', 'HelicalGear', 'InternalGear', 'LeadScrew', 'ModelError',
    'PlanetaryGearSet', 'RollerScrew', 'SpurGear', 'Stage', 'WormGear',
    'd_u_d_eta_aiding', 'd_u_d_eta_opposing', 'efficiencies', 'eta_aiding',
    'eta_aiding_from_opposing', 'eta_opposing', 'eta_opposing_from_aiding', 'min_teeth',
    'series_efficiencies', 'total_squared_error', 'u_from_eta_aiding', 'u_from_eta_opposing',
]
