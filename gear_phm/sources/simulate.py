"""Simulate source: the seeded plant of :mod:`gear_phm.simulation` at a fixed sample rate."""
from __future__ import annotations

from collections.abc import Generator, Mapping, Sequence
from dataclasses import replace
import math
from typing import Any

import numpy as np

from gear_phm.interfaces import TRUTH_LAYOUT, TRUTH_NO_LOAD, TRUTH_OIL
from gear_phm.simulation import (config_from_parameters, PARAMETERS, SimulationConfig,
                                 SimulationResult, Simulator)
from gear_phm.sources import Item, one_line, Sample, SourceError

_LAYOUT = dict(TRUTH_LAYOUT)
#: Sample's fields of the extended truth and the SimulationResult arrays they hold.
_EXTENDED = (('no_load', _LAYOUT[TRUTH_NO_LOAD]), ('oil', _LAYOUT[TRUTH_OIL]))

#: Samples generated per simulation chunk [s of simulated time].
SIM_CHUNK_S = 0.5


class SimulateSource:
    """Samples k = 0, 1, ... at elapsed time round(k 1e9 / rate) [ns].

    ``duration`` [s] > 0 stops after floor(duration rate) samples; 0 runs until the consumer
    stops.
    """

    mode = 'simulate'
    speed = 1.0

    def __init__(self, config: SimulationConfig, rate: float, duration: float) -> None:
        self.config = config
        self.rate = float(rate)
        self.duration = float(duration)
        self.dropped: dict[str, int] = {}
        if self.duration > 0.0:
            friction = float(config.wear.value(self.duration))
            _, eta_d, _ = config.plant.efficiencies(friction)
            if not float(eta_d) > 0.0:
                raise SourceError(f'parameter duration: friction {friction:.4g} at '
                                  f'{self.duration:g} s gives eta_D <= 0 (gearbox jams)')

    @classmethod
    def from_parameters(cls, values: Mapping[str, Any], rate: float,
                        duration: float) -> SimulateSource:
        """Build from the flat simulation parameters (names of gear_phm.simulation.PARAMETERS)."""
        try:
            config = config_from_parameters({spec.name: values[spec.name] for spec in PARAMETERS})
        except ValueError as exc:
            raise SourceError(f'parameter {one_line(exc)}') from None
        return cls(config, rate, duration)

    def items(self) -> Generator[tuple[int, Item], None, None]:
        """One :class:`Sample` per sample time; a jam of an unbounded run raises ValueError."""
        simulator = Simulator(self.config)
        for index, t in self._chunks():
            r = simulator.sample(t)
            columns = zip(r.position_motor.tolist(), r.position_load.tolist(),
                          r.velocity_motor.tolist(), r.velocity_load.tolist(),
                          r.effort_motor.tolist(), r.effort_load.tolist(), r.u.tolist(),
                          r.friction.tolist(), r.eta_opposing.tolist(), r.eta_aiding.tolist())
            extra = _extended([self.config], [r])
            for i, (pm, pl, vm, vl, em, el, u, friction, eta_d, eta_i) in enumerate(columns):
                elapsed_ns = int(round(float(index[i]) * 1e9 / self.rate))
                sample = Sample((pm, pl), (vm, vl), (em, el), (u, friction), (eta_d, eta_i))
                yield elapsed_ns, replace(sample, **{k: v[i] for k, v in extra.items()}) \
                    if extra else sample

    def _chunks(self) -> Generator[tuple[np.ndarray, np.ndarray], None, None]:
        """Yield (sample indices, sample times [s]) of each simulation chunk.

        The samples of the idle gap are left out (the stamps jump over it).
        """
        rate = self.rate
        gap = self.config.idle_gap
        total = int(math.floor(self.duration * rate + 1e-9)) if self.duration > 0 else None
        chunk = max(1, int(round(SIM_CHUNK_S * rate)))
        index = 0
        while total is None or index < total:
            count = chunk if total is None else min(chunk, total - index)
            indices = np.arange(index, index + count)
            t = indices / rate
            index += count
            if gap.enabled:
                running = ~gap.idle(t)
                indices, t = indices[running], t[running]
                if not t.size:
                    continue
            yield indices, t

    def describe(self) -> Sequence[tuple[str, Any]]:
        return [('rate_hz', self.rate)]


class SimulateDrivesSource(SimulateSource):
    """Many drives in one stream: one :class:`Sample` per instant holds every drive's pairs.

    ``configs``: one simulation per drive (each its own simulator, all sharing the sample
    times), as ``gear-phm simulate --transmissions`` writes them.
    """

    def __init__(self, configs: Sequence[SimulationConfig], rate: float,
                 duration: float) -> None:
        if not configs:
            raise SourceError('no drive to simulate')
        for config in configs:
            super().__init__(config, rate, duration)
        if len({config.idle_gap for config in configs}) > 1:
            raise SourceError('the drives of one stream must share their idle gap '
                              '(idle_gap_at, idle_gap_duration)')
        self.configs = list(configs)

    def items(self) -> Generator[tuple[int, Item], None, None]:
        """One :class:`Sample` of all drives per sample time."""
        simulators = [Simulator(config) for config in self.configs]
        for index, t in self._chunks():
            runs = [simulator.sample(t) for simulator in simulators]
            extra = _extended(self.configs, runs)

            def rows(*names: str) -> list[tuple[float, ...]]:
                table = np.column_stack([getattr(r, name) for r in runs for name in names])
                return [tuple(row) for row in table.tolist()]
            columns = zip(rows('position_motor', 'position_load'),
                          rows('velocity_motor', 'velocity_load'),
                          rows('effort_motor', 'effort_load'), rows('u', 'friction'),
                          rows('eta_opposing', 'eta_aiding'))
            for i, (position, velocity, effort, friction, efficiency) in enumerate(columns):
                elapsed_ns = int(round(float(index[i]) * 1e9 / self.rate))
                sample = Sample(position, velocity, effort, friction, efficiency)
                yield elapsed_ns, replace(sample, **{k: v[i] for k, v in extra.items()}) \
                    if extra else sample

    def describe(self) -> Sequence[tuple[str, Any]]:
        return [('rate_hz', self.rate), ('drives', len(self.configs))]


def _extended(configs: Sequence[SimulationConfig], runs: Sequence[SimulationResult]
              ) -> dict[str, list[tuple[float, ...]]]:
    """Per sample, the extended truth fields of :class:`Sample` (each drive's, in order).

    Only the fields some drive has; every drive contributes its values then (a drive without
    the effect: no loss, a scale of 1), so each drive's values keep their place.
    """
    extra: dict[str, list[tuple[float, ...]]] = {}
    wanted: list[tuple[str, tuple[str, ...]]] = [
        (name, fields) for name, fields in _EXTENDED if any(c.extended_truth for c in configs)]
    if any(c.publish_temperature for c in configs):
        wanted.append(('temperature', ('oil_temperature',)))
    for name, fields in wanted:
        table = np.column_stack([getattr(r, f) if f else np.zeros(len(r)) for r in runs
                                 for f in fields])
        extra[name] = [tuple(row) for row in table.tolist()]
    return extra
