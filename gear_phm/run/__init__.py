"""One drive's run, ROS-free: its names, its estimator and its health, with their statuses.

The unit that every runner of gear_phm repeats once per drive, whether one transmission or a
``transmissions`` list (a list of one for the single transmission):

- :class:`~gear_phm.run.names.DriveNames`: its topics, status names, plot file and messages;
- :class:`~gear_phm.run.estimator.DriveEstimator`: its
  :class:`~gear_phm.estimation.EstimatorPipeline`, the estimator status and its resets, and
  the checks of its data against its parameters;
- :class:`~gear_phm.run.health.DriveHealth`: its :class:`~gear_phm.prognostics.HealthAssessor`,
  the health status and its resets, and the time each level was first seen.

The live estimator node holds a DriveEstimator per drive, the diagnostics node a DriveHealth
per drive; ``gear-phm analyze`` both per drive, plus the histories it returns
(:class:`gear_phm.offline.drive.DriveRun`).
"""
from gear_phm.run.estimator import DriveEstimator
from gear_phm.run.health import DriveHealth
from gear_phm.run.names import DriveNames, ESTIMATOR_STATUS_NAME

__all__ = ['DriveEstimator', 'DriveHealth', 'DriveNames', 'ESTIMATOR_STATUS_NAME']
