"""Online estimation of the gearbox friction parameter u (numpy + filterpy, no ROS).

- :mod:`.records`: :class:`JointSample` in, :class:`FrictionEstimate` out.
- :mod:`.powerflow`: power-flow classification of samples from shaft powers.
- :mod:`.windows`: energy windows within one phase -> efficiency -> pseudo-measurement of u.
- :mod:`.kalman`: filterpy Kalman filter on [u, du/dt] with gating.
- :mod:`.pipeline`: the whole estimator over batches of samples, composed of
  :mod:`.stamps` (the stamp screen), :mod:`.timeline` (stamp and operating time),
  :mod:`.fusion` (windows into the filter, with :mod:`.inertia` and :mod:`.no_load`),
  :mod:`.predictions`, :mod:`.grouping` (one estimate per stamp), :mod:`.quality` (data-quality
  checks), :mod:`.reasons` (the counters), :mod:`.status` (its /diagnostics status) and
  :mod:`.state` (its persisted state).
- :mod:`.summary`: its final state and counters as a record.
"""
from gear_phm.estimation.config import EstimatorConfig, PARAMETERS
from gear_phm.estimation.kalman import FrictionFilter, UpdateResult
from gear_phm.estimation.pipeline import EstimatorPipeline, StatusSnapshot
from gear_phm.estimation.powerflow import classify
from gear_phm.estimation.records import FrictionEstimate, JointSample
from gear_phm.estimation.summary import EstimatorSummary
from gear_phm.estimation.windows import EnergyIntegrator, Measurement, to_measurement, Window

__all__ = ['PARAMETERS', 'EnergyIntegrator', 'EstimatorConfig', 'EstimatorPipeline',
           'EstimatorSummary', 'FrictionEstimate', 'FrictionFilter', 'JointSample', 'Measurement',
           'StatusSnapshot', 'UpdateResult', 'Window', 'classify', 'to_measurement']
