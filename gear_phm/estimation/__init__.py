"""Online estimation of the gearbox friction parameter u (numpy + filterpy, no ROS).

- :mod:`.powerflow`: power-flow codes of docs/architecture.md from shaft powers.
- :mod:`.windows`: energy windows within one phase -> efficiency -> pseudo-measurement of u.
- :mod:`.kalman`: filterpy Kalman filter on [u, du/dt] with gating.
- :mod:`.pipeline`: the whole estimator over batches or single JointState messages, emitting
  the output records that the node publishes and ``gear-phm analyze`` writes.
"""
from gear_phm.estimation.config import EstimatorConfig, PARAMETERS
from gear_phm.estimation.kalman import FrictionFilter, UpdateResult
from gear_phm.estimation.pipeline import EstimatorPipeline
from gear_phm.estimation.powerflow import classify, shaft_powers
from gear_phm.estimation.windows import EnergyIntegrator, Measurement, to_measurement, Window

__all__ = ['PARAMETERS', 'EnergyIntegrator', 'EstimatorConfig', 'EstimatorPipeline',
           'FrictionFilter', 'Measurement', 'UpdateResult', 'Window', 'classify',
           'shaft_powers', 'to_measurement']
