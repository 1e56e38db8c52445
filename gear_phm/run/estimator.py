"""One drive's estimator: its pipeline, its estimator status and its resets (ROS-free)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from gear_phm.estimation import (EstimatorConfig, EstimatorPipeline, Measurement,
                                 StatusSnapshot)
from gear_phm.run.names import DriveNames
from gear_phm.status import StatusOut


class DriveEstimator:
    """One drive's :class:`~gear_phm.estimation.EstimatorPipeline` and what it reports.

    ``on_measurement`` is the pipeline's (each measured window, accepted or not). Raises
    ValueError when the configuration is refused (the pipeline's reason).
    """

    def __init__(self, config: EstimatorConfig, names: DriveNames,
                 on_measurement: Callable[[Measurement, bool], None] | None = None) -> None:
        self.pipeline = EstimatorPipeline(config, on_measurement=on_measurement)
        self.names = names
        #: learning resets on purpose (a reset service)
        self.resets = 0
        #: the caller's clock at the drive's newest sample [ns] (None before one)
        self.last_sample_ns: int | None = None

    def status(self, messages_received: int | None = None,
               snapshot: StatusSnapshot | None = None) -> StatusOut:
        """Return the estimator status under the drive's name and hardware_id (the pipeline's)."""
        return replace(self.pipeline.status(self.names.estimator_status, messages_received,
                                            snapshot), hardware_id=self.names.hardware_id)

    def reset(self) -> None:
        """Forget what the pipeline learned, on purpose; counted in :attr:`resets`."""
        self.pipeline.reset()
        self.resets += 1

    def watch(self, now_ns: int) -> None:
        """Flag a sensor timeout once the drive has had no sample for its sensor_timeout.

        ``now_ns``: the caller's clock [ns], the clock of :attr:`last_sample_ns`.
        """
        if self.last_sample_ns is not None:
            self.pipeline.on_silence((now_ns - self.last_sample_ns) * 1e-9)

    def refusal(self) -> str:
        """Return why the drive's data contradict its parameters ('' when they do not).

        The pipeline's checks (ratio against the speeds, energy out above energy in, a
        reversed torque sign), the first that fails, with where the user sets the parameter.
        """
        pipeline, names = self.pipeline, self.names
        fix = pipeline.reversed_torque_fix()
        for problem, where in (
                (pipeline.ratio_check(), names.ratio_where),
                (pipeline.over_unity(), ''),
                (pipeline.reversed_torque(),
                 '' if fix is None else names.param_where.format(*fix))):
            if problem:
                return names.label + problem + (f' ({where})' if where else '')
        return ''
