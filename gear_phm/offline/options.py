"""``gear-phm analyze``'s options: one :class:`AnalyzeOptions`, checked, and the drives' setups.

:func:`split_options` routes the estimator and health parameters by name; :func:`drive_setups`
turns the options into one :class:`DriveSetup` per drive: one for the single transmission
(the global ratio and joints), one per entry of ``transmissions``.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from gear_phm import interfaces
from gear_phm.errors import GearPhmError
from gear_phm.estimation import EstimatorConfig
from gear_phm.parameters import (DIAGNOSTICS_RATE, HARDWARE_ID, LOAD_JOINT, MOTOR_JOINT, RATIO,
                                 STAMP_SOURCE, TRANSMISSION_NAME)
from gear_phm.prognostics import HealthConfig, ShapePrior
from gear_phm.prognostics.config import NOT_OFFLINE_OPTIONS
from gear_phm.run import DriveNames
from gear_phm.transmissions import (DRIVE_OWN, drive_own_given, load_transmissions,
                                    parse_transmissions, Transmission, TransmissionsError)

#: ``analyze_bag``'s default ``history``: the returned histories keep 10 000 to 20 000 records
#: each, whatever the bag (a few MiB).
HISTORY = 10_000


class AnalysisError(GearPhmError, ValueError):
    """A problem with the input or the options: one line, meant for the user."""


def split_options(ratio: float, options: Mapping[str, Any]
                  ) -> tuple[EstimatorConfig, HealthConfig]:
    """Route keyword options to the estimator or the health parameters by name.

    Raises AnalysisError for an unknown name or a refused value.
    """
    estimator_names = {f.name for f in fields(EstimatorConfig)} - {RATIO.name}
    health_names = {f.name for f in fields(HealthConfig)} - set(NOT_OFFLINE_OPTIONS)
    unknown = sorted(set(options) - estimator_names - health_names)
    if unknown:
        raise AnalysisError(f'unknown option(s) {unknown}; estimator: '
                            f'{sorted(estimator_names)}; health: {sorted(health_names)}')
    try:
        estimator = EstimatorConfig(ratio=float(ratio), **{
            k: v for k, v in options.items() if k in estimator_names})
        health = HealthConfig(ratio=float(ratio), **{
            k: v for k, v in options.items() if k in health_names})
    except (TypeError, ValueError) as exc:
        raise AnalysisError(str(exc)) from None
    return estimator, health


@dataclass(frozen=True)
class AnalyzeOptions:
    """What :func:`~gear_phm.offline.engine.analyze_bag` is asked to do (its docstring).

    ``parameters``: the estimator or health parameters by name (as config/estimator.yaml and
    config/diagnostics.yaml, e.g. ``eta_opposing_min``); :meth:`of` takes them as keywords.
    """

    ratio: float | None = None
    motor_joint: str = str(MOTOR_JOINT.default)
    load_joint: str = str(LOAD_JOINT.default)
    topic: str = interfaces.JOINT_STATES
    out: str | Path | None = None
    overwrite: bool = False
    plot: bool = True
    progress: bool = False
    transmission_name: str = str(TRANSMISSION_NAME.default)
    hardware_id: str = str(HARDWARE_ID.default)
    diagnostics_rate: float = float(DIAGNOSTICS_RATE.default)
    stamp_source: str = str(STAMP_SOURCE.default)
    history: int | None = HISTORY
    prior: ShapePrior | None = None
    transmissions: Any = None
    jobs: int = 1
    parameters: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, ratio: float | None = None, **keywords: Any) -> AnalyzeOptions:
        """Return the options of ``analyze_bag``'s keywords: its own, else parameters."""
        own = {f.name for f in fields(cls)} - {'ratio', 'parameters'}
        return cls(ratio, **{k: v for k, v in keywords.items() if k in own},
                   parameters={k: v for k, v in keywords.items() if k not in own})

    def checked(self) -> AnalyzeOptions:
        """Return the options with the topic, history, rate and stamp source checked.

        The rate and the stamp source as their parameters hold them. Raises AnalysisError.
        """
        topic, history = self.topic, self.history
        if not isinstance(topic, str) or not topic:
            raise AnalysisError(f'topic must be a topic name, got {topic!r}')
        if history is not None and (isinstance(history, bool) or not isinstance(history, int)
                                    or history < 1):
            raise AnalysisError(f'history must be an integer >= 1 or None, got {history!r}')
        try:            # the diagnostics node's `rate` and its range
            rate = float(replace(DIAGNOSTICS_RATE, name='diagnostics_rate').check(
                self.diagnostics_rate))
            stamp_source = str(STAMP_SOURCE.check(self.stamp_source))
        except ValueError as exc:
            raise AnalysisError(str(exc)) from None
        return replace(self, diagnostics_rate=rate, stamp_source=stamp_source)

    def checked_jobs(self) -> int:
        """Return ``jobs`` checked (AnalysisError if not an integer >= 0)."""
        jobs = self.jobs
        if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 0:
            raise AnalysisError(f'jobs must be an integer >= 0 (0: one per core), got {jobs!r}')
        return jobs


@dataclass(frozen=True)
class DriveSetup:
    """One drive to analyse: its names, its configurations and its joints."""

    names: DriveNames
    estimator_config: EstimatorConfig
    health_config: HealthConfig
    motor_joint: str
    load_joint: str


def drive_setups(options: AnalyzeOptions) -> list[DriveSetup]:
    """Return the drives of ``options``: the single transmission, or each of ``transmissions``.

    Raises AnalysisError for a bad option, joint or transmissions list, and for a drive's own
    option given with ``transmissions``.
    """
    if options.transmissions is None:
        return [_single(options)]
    given = [name for name, value, default in zip(DRIVE_OWN, (
        options.ratio, options.motor_joint, options.load_joint, options.transmission_name,
        options.hardware_id), (None, MOTOR_JOINT.default, LOAD_JOINT.default,
                               TRANSMISSION_NAME.default, HARDWARE_ID.default))
        if value != default]
    if given:
        raise AnalysisError(drive_own_given(given))
    setups = []
    for drive in _drives(options.transmissions):
        estimator_config, health_config = split_options(
            drive.ratio, {**options.parameters, **drive.offline_options()})
        setups.append(DriveSetup(DriveNames.of(drive.name), estimator_config, health_config,
                                 drive.motor_joint, drive.load_joint))
    return setups


def _single(options: AnalyzeOptions) -> DriveSetup:
    """Return the single transmission's setup (its ratio and joints are the options')."""
    if options.ratio is None:
        raise AnalysisError('give the ratio (one transmission) or transmissions (many)')
    estimator_config, health_config = split_options(options.ratio, options.parameters)
    motor_joint, load_joint = options.motor_joint, options.load_joint
    if not isinstance(motor_joint, str) or not isinstance(load_joint, str) \
            or not motor_joint or not load_joint or motor_joint == load_joint:
        raise AnalysisError(f'motor_joint and load_joint must be distinct non-empty '
                            f'names, got {motor_joint!r} and {load_joint!r}')
    names = DriveNames.single(options.transmission_name,
                              options.hardware_id or options.transmission_name)
    return DriveSetup(names, estimator_config, health_config, motor_joint, load_joint)


def _drives(transmissions: Any) -> tuple[Transmission, ...]:
    """Return the drives of the ``transmissions`` option (AnalysisError if bad)."""
    try:
        if isinstance(transmissions, (str, Path)):
            return load_transmissions(transmissions)
        if isinstance(transmissions, Mapping):
            return parse_transmissions(transmissions)
        drives = tuple(transmissions)
    except TransmissionsError as exc:
        raise AnalysisError(str(exc)) from None
    except TypeError:
        drives = ()
    if not drives or not all(isinstance(d, Transmission) for d in drives):
        raise AnalysisError('transmissions must be a file, its YAML document or a non-empty '
                            'sequence of Transmission records')
    return drives


def bag_paths(path_or_paths: str | Path | Sequence[str | Path]) -> list[str | Path]:
    """Return ``analyze_bag``'s bags as a list (AnalysisError if there is none)."""
    paths = [path_or_paths] if isinstance(path_or_paths, (str, Path)) else list(path_or_paths)
    if not paths:
        raise AnalysisError('no bag given')
    return paths
