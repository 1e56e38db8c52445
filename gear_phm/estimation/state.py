"""The estimator's persisted state: a typed record and its JSON-safe layout (no ROS).

:class:`PipelineState` is what a restart of ``EstimatorPipeline`` needs to continue as if it
never stopped: its counters, its time axes and the newest estimate's values, and its parts'
own states (the filter's, in ``kalman``; the learned inertia, the open energy window, the
no-load learner and its band), kept as the JSON objects those parts write.
:meth:`PipelineState.to_json` writes the layout of a state file's ``state``
(:mod:`gear_phm.persistence`); :meth:`PipelineState.from_json` reads it back, and that of any
state file written before (the keys added since are optional).

Layout: ``filter``, ``counts`` (by reason), ``samples_seen``, ``samples_used``,
``samples_rejected``, ``samples_missing``, ``windows_used``, ``operating_time`` [s],
``max_stamp``, ``last_group_stamp``, ``origin_ns`` [ns, or null], ``grid``, ``last_code``,
``last_eta``, ``last_stamp`` [ns, or null], ``carry`` (null, or the five floats of a
measurement carried to the next estimate), ``inertia``, ``window``, ``no_load`` and
``no_load_band``. Floats go through :func:`~gear_phm.persistence.encode_float`.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from gear_phm.persistence import decode_float, encode_float

#: A state as a ``to_state()`` writes it and its ``from_state()`` reads it: the pipeline's and
#: each of its parts' (JSON-safe, of values of several types, read by key).
StateDict = dict[str, Any]
#: A measurement carried to the next estimate: u [-], its variance [-^2], the operating time
#: it holds at [s], its direction share h [-] and the bias subtracted from it [-].
Carry = tuple[float, float, float, float, float]


def _integer(value: object) -> int:
    """Return ``int(value)``; TypeError for what is not a number or a string."""
    if isinstance(value, (int, float, str)):
        return int(value)
    msg = f'expected an integer, got {value!r}'
    raise TypeError(msg) from None


def _stamp(value: object) -> int | None:
    """Return a stamp [ns] or None (JSON null)."""
    return None if value is None else _integer(value)


def _part(value: object) -> StateDict:
    """Return a part's state object; TypeError for what is not one."""
    if not isinstance(value, dict):
        msg = f'expected an object, got {value!r}'
        raise TypeError(msg) from None
    return value


def _carry(value: object) -> Carry | None:
    """Return a carried measurement; an older one's h and bias are 0 (not re-corrected)."""
    if value is None:
        return None
    if not isinstance(value, Sequence) or isinstance(value, str):
        msg = f'expected a list of numbers, got {value!r}'
        raise TypeError(msg) from None
    u, variance, at, h, bias = (decode_float(v) for v in [*value, 0.0, 0.0][:5])
    return u, variance, at, h, bias


@dataclass(frozen=True)
class PipelineState:
    """What a restart needs to continue as if it never stopped; see the module docstring.

    ``counts``: the counters by reason; the samples seen, used, rejected and missing and the
    windows used; ``operating_time`` [s]; the stamps [ns] of the newest sample screened
    (``max_stamp``), of the newest estimate (``last_group_stamp``), of the time origin and of
    the newest timely sample (``last_stamp``); ``grid``: the publish grid's newest cell;
    ``last_code`` and ``last_eta``: the newest power flow and measured efficiency; ``carry``:
    a measurement whose estimate was dropped. The parts' states: None where a state file
    written before they were kept has none (the part then starts afresh).
    """

    counts: dict[str, int]
    samples_seen: int
    samples_used: int
    samples_rejected: int
    samples_missing: int
    windows_used: int
    operating_time: float
    max_stamp: int | None
    last_group_stamp: int | None
    origin_ns: int | None
    grid: int | None
    last_code: int
    last_eta: float
    last_stamp: int | None
    carry: Carry | None
    kalman: StateDict
    inertia: StateDict | None
    window: StateDict | None
    no_load: StateDict | None
    no_load_band: StateDict | None

    def to_json(self) -> dict[str, object]:
        """Return the JSON-safe layout of the module docstring (every part present)."""
        return {
            'filter': self.kalman, 'counts': dict(self.counts),
            'samples_seen': self.samples_seen, 'samples_used': self.samples_used,
            'samples_rejected': self.samples_rejected,
            'samples_missing': self.samples_missing, 'windows_used': self.windows_used,
            'operating_time': encode_float(self.operating_time),
            'max_stamp': self.max_stamp, 'last_group_stamp': self.last_group_stamp,
            'origin_ns': self.origin_ns, 'grid': self.grid, 'last_code': self.last_code,
            'last_eta': encode_float(self.last_eta), 'last_stamp': self.last_stamp,
            'carry': None if self.carry is None else [encode_float(v) for v in self.carry],
            'inertia': self.inertia, 'window': self.window,
            'no_load': self.no_load, 'no_load_band': self.no_load_band,
        }

    @classmethod
    def from_json(cls, state: Mapping[str, object], reasons: Sequence[str]) -> PipelineState:
        """Read :meth:`to_json`'s layout, or an older one's; ``reasons``: the counters kept.

        A counter the state does not hold starts at 0; one it holds that is not in
        ``reasons`` is left out. Raises KeyError, ValueError or TypeError on a malformed
        state (the parts' own states are checked by the parts).
        """
        counts = state['counts']
        if not isinstance(counts, Mapping):
            msg = f'counts: expected an object, got {counts!r}'
            raise TypeError(msg) from None
        no_load = 'no_load' in state        # a state without it starts the no-load part anew
        return cls(
            {key: _integer(counts.get(key, 0)) for key in reasons},
            _integer(state['samples_seen']), _integer(state['samples_used']),
            _integer(state['samples_rejected']), _integer(state['samples_missing']),
            _integer(state['windows_used']), decode_float(state['operating_time']),
            _stamp(state['max_stamp']), _stamp(state['last_group_stamp']),
            _stamp(state['origin_ns']), _stamp(state['grid']), _integer(state['last_code']),
            decode_float(state['last_eta']), _stamp(state['last_stamp']),
            _carry(state.get('carry')), _part(state['filter']),
            _part(state['inertia']) if 'inertia' in state else None,
            _part(state['window']) if 'window' in state else None,
            _part(state['no_load']) if no_load else None,
            _part(state['no_load_band']) if no_load else None)
